"""Experiments: the paper's tables and figures, with resumable results."""
