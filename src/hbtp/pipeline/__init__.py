"""The HBTP pipeline: LLM reasoning, pruning, planning, reflective feedback and the fallback."""

from hbtp.pipeline.loop import LoopOptions, LoopResult, RoundRecord, run_hbtp

__all__ = ["LoopOptions", "LoopResult", "RoundRecord", "run_hbtp"]
