"""Offline tools: fitters that write the tables the runtime package serves (``python -m tools.<name>``)."""
