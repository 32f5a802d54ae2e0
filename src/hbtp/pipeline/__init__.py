"""The HBTP pipeline: LLM reasoning, pruning, planning, reflective feedback and the fallback."""

from hbtp.pipeline.loop import LoopOptions, run_hbtp
from hbtp.pipeline.results import Ending, Exchange, LoopResult, Outcome, RoundRecord, RoundStatus

__all__ = ["Ending", "Exchange", "LoopOptions", "LoopResult", "Outcome", "RoundRecord", "RoundStatus", "run_hbtp"]
