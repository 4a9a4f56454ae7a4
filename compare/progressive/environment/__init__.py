"""Environment light: its occlusion, its shadow maps, and the sun taken out of it."""
