"""The HBTP pipeline: LLM reasoning, pruning, planning, reflective feedback and the fallback."""

from hbtp.pipeline.auto import DEFAULT_PROBE_SECONDS, AutoResult, plan_auto
from hbtp.pipeline.loop import LoopOptions, run_hbtp
from hbtp.pipeline.results import Ending, Exchange, LoopResult, Outcome, RoundRecord, RoundStatus

__all__ = [
    "DEFAULT_PROBE_SECONDS",
    "AutoResult",
    "Ending",
    "Exchange",
    "LoopOptions",
    "LoopResult",
    "Outcome",
    "RoundRecord",
    "RoundStatus",
    "plan_auto",
    "run_hbtp",
]
