"""``hbtp train``: teach the local model a world, from examples the planner labels.

The steps, each resumable: the examples are generated (or read back from the work folder when the
same request made them), an adapter is trained on them (:mod:`hbtp.train.lora`, checkpointed),
written as a GGUF adapter (:mod:`hbtp.train.adapter_file`), and judged on the held-back examples
(:mod:`hbtp.train.evaluate`). Before any work, the machine must have the memory and disk a run
needs (:data:`NEEDED_MEMORY_MB`, :data:`NEEDED_DISK_MB`).
"""

from __future__ import annotations

import hashlib
import json
import logging
import shutil
import time
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from hbtp.deadline import Deadline
from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.files import InputKind, read_text, write_atomically
from hbtp.llm.backends.adapters import KEY_BASE, KEY_FILLED, KEY_WORLD, PROMPT_FORMAT, world_key
from hbtp.llm.backends.local import default_model_sha256, resolve_model_path
from hbtp.train.adapter_file import write_adapter
from hbtp.train.evaluate import HeldOutScore, evaluate_in_child
from hbtp.train.example_set import EXAMPLES_FORMAT, ExampleSet, make_examples
from hbtp.train.examples import Example
from hbtp.train.lora import TrainReport, TrainSettings, train

log = logging.getLogger(__name__)

#: What a run needs free before it starts: memory for the dequantized model and its gradients
#: (3.3-4.5 GB measured at peak, by the world), disk for the checkpoints and the adapter.
NEEDED_MEMORY_MB = 5_000
NEEDED_DISK_MB = 200


@dataclass(frozen=True)
class TrainRequest:
    """One ``hbtp train``: the world, how many examples, how to train, where things go."""

    scenario: Scenario
    source: dict[str, object]  # how a child process loads the world again
    count: int = 2_000
    held_out: float = 0.1
    settings: TrainSettings = field(default_factory=TrainSettings)
    out: Path | None = None  # the adapter (default: the cache, where --llm local finds it)
    work: Path | None = None  # checkpoints and examples (default: the cache's train folder)
    time_limit: float | None = None
    evaluate: bool = True
    #: Teach instructions -> goals too (:mod:`hbtp.train.goal_examples`), beside goals -> hints.
    instructions: bool = True
    #: The command line that asked for this run (kept in the report beside the adapter).
    command: str = ""
    #: Judge the base model too (as ``--llm local`` asks it without an adapter: demonstrations from
    #: the world's pool) on the same held-back examples: the before of the adapter's after.
    baseline: bool = False
    #: Teach plans without the actions the check puts back (:mod:`hbtp.train.abridge`).
    abridge: bool = False
    #: Teach goals -> hints (left out for an adapter that only reads instructions).
    hints: bool = True


@dataclass(frozen=True)
class TrainOutcome:
    """What ``hbtp train`` made and measured."""

    request: TrainRequest
    adapter: Path
    size: int
    examples: ExampleSet
    report: TrainReport
    score: HeldOutScore | None
    seconds: float
    base_score: HeldOutScore | None = None

    def to_dict(self) -> dict[str, Any]:
        kinds = Counter(e.kind.value for e in self.examples.train)
        return {
            "command": self.request.command,
            "scenario": self.request.scenario.name,
            "settings": asdict(self.request.settings),
            "requested_goals": self.request.count,
            "train_examples_by_kind": dict(sorted(kinds.items())),
            "abridged": self.request.abridge,
            "filled_predicates": list(self.examples.filled),
            "adapter": str(self.adapter),
            "bytes": self.size,
            "train_examples": len(self.examples.train),
            "held_out_examples": len(self.examples.held_out),
            "dropped_evaluation_goals": self.examples.dropped,
            "steps": self.report.steps,
            "first_loss": self.report.first_loss,
            "last_loss": self.report.last_loss,
            "training_s": round(self.report.seconds, 1),
            "resumed_at_step": self.report.resumed_at,
            "held_out": None if self.score is None else self.score.to_dict(),
            "held_out_base_model": None if self.base_score is None else self.base_score.to_dict(),
            "total_s": round(self.seconds, 1),
        }


def check_resources(folder: Path) -> None:
    """Refuse to start without the memory and disk a run needs (one line each)."""
    available = _available_memory_mb()
    if available is not None and available < NEEDED_MEMORY_MB:
        raise InputError(f"training needs about {NEEDED_MEMORY_MB} MB of free memory; {available:.0f} MB are free")
    folder.mkdir(parents=True, exist_ok=True)
    free = shutil.disk_usage(folder).free / 1e6
    if free < NEEDED_DISK_MB:
        raise InputError(f"training needs {NEEDED_DISK_MB} MB of free disk in {folder}; {free:.0f} MB are free")


def _available_memory_mb() -> float | None:
    try:
        for line in Path("/proc/meminfo").read_text(encoding="ascii").splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) / 1000
    except (OSError, ValueError, IndexError):
        return None
    return None


def _examples(request: TrainRequest, work: Path) -> ExampleSet:
    """The request's examples, read back from ``work`` when the same request made them."""
    asked = [request.source, request.count, request.held_out, request.settings.seed, request.instructions]
    if request.abridge:  # (a key of its own; the keys of full labels stay those of earlier runs)
        asked.append("abridged")
    if not request.hints:
        asked.append("no hints")
    key = hashlib.sha256(json.dumps([*asked, PROMPT_FORMAT, EXAMPLES_FORMAT], sort_keys=True).encode()).hexdigest()
    stored = work / "examples.json"
    if stored.is_file():
        data = json.loads(read_text(stored, InputKind.DATASET))
        if data.get("key") == key:
            return ExampleSet(
                tuple(Example.from_dict(e) for e in data["train"]),
                tuple(Example.from_dict(e) for e in data["held_out"]),
                int(data["dropped"]),
                tuple(data.get("filled", ())),
            )
    examples = make_examples(
        request.scenario,
        request.count,
        seed=request.settings.seed,
        held_out=request.held_out,
        instructions=request.instructions,
        abridge=request.abridge,
        hints=request.hints,
    )
    document = {
        "key": key,
        "train": [e.to_dict() for e in examples.train],
        "held_out": [e.to_dict() for e in examples.held_out],
        "dropped": examples.dropped,
        "filled": list(examples.filled),
    }
    write_atomically(stored, json.dumps(document, sort_keys=True))
    return examples


def run_training(
    request: TrainRequest,
    default_work: Path,
    progress: Callable[[Iterator[int], int, int], Iterator[int]] | None = None,
) -> TrainOutcome:
    """Generate, train, write and judge (see the module docstring)."""
    started = time.monotonic()
    deadline = None if request.time_limit is None else Deadline(request.time_limit)
    scenario = request.scenario
    world = world_key(scenario.domain_file, scenario.problem_file)
    work = request.work or default_work / world
    check_resources(work)
    examples = _examples(request, work)
    base = resolve_model_path(None)
    state, report = train(examples.train, request.settings, base, work, deadline=deadline, progress=progress)
    out = request.out or default_work.parent / "adapters" / f"{world}.gguf"
    out.parent.mkdir(parents=True, exist_ok=True)
    facts: dict[str, str | int] = {
        KEY_WORLD: world,
        KEY_BASE: default_model_sha256() or "",
        "hbtp.scenario": scenario.name,
        "hbtp.seed": request.settings.seed,
        "hbtp.rank": request.settings.rank,
        "hbtp.epochs": request.settings.epochs,
        "hbtp.train_examples": len(examples.train),
        "hbtp.steps": report.steps,
    }
    if examples.filled:
        facts[KEY_FILLED] = ",".join(examples.filled)
    size = write_adapter(state, request.settings.alpha, base, out, facts)
    score = evaluate_in_child(request.source, out, examples.held_out, work) if request.evaluate else None
    base_score = evaluate_in_child(request.source, None, examples.held_out, work) if request.baseline else None
    outcome = TrainOutcome(request, out, size, examples, report, score, time.monotonic() - started, base_score)
    write_atomically(out.with_suffix(".json"), json.dumps(outcome.to_dict(), indent=1, sort_keys=True) + "\n")
    return outcome


__all__ = ["NEEDED_DISK_MB", "NEEDED_MEMORY_MB", "TrainOutcome", "TrainRequest", "check_resources", "run_training"]
