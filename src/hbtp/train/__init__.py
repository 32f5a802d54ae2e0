"""Teaching the local model a world (``hbtp train``): examples the planner labels, a LoRA adapter
trained on them, written for llama.cpp, and judged on held-back goals.

Training needs the ``train`` extra (torch, transformers, peft, gguf), imported only when it runs;
the verbaliser (:mod:`hbtp.train.verbalise`) needs nothing more than hbtp, and ``hbtp bench
instructions`` uses it too.
"""

from hbtp.train.example_set import ExampleSet, make_examples
from hbtp.train.examples import Example, ExampleKind, LeakError
from hbtp.train.lora import TrainingStopped, TrainReport, TrainSettings

__all__ = [
    "Example",
    "ExampleKind",
    "ExampleSet",
    "LeakError",
    "TrainReport",
    "TrainSettings",
    "TrainingStopped",
    "make_examples",
]
