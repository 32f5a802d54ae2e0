"""hbtp: heuristic behavior tree planning with LLM reasoning."""

__version__ = "0.1.0"
