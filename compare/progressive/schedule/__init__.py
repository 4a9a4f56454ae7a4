"""The sample schedule, no GL: the sample distributor (the paper's Algorithm 1), frame budgets, sample sequences."""
