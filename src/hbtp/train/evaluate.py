"""How well a taught model answers goals it was never trained on.

Each held-back example's goal is asked of the local model with the adapter, as ``--llm local``
asks it (the short prompt, constrained decoding), and the answer is judged three ways:

* exact: the action list is the label's (one optimal plan of several, so this is strict);
* covered: the predicates and objects named include those of the label's plan;
* NF: the planner, searching only the space the answer names (HBTP-S, as a loop round does),
  finds a tree: the paper's "solved without feedback".

Each held-back instruction is asked as ``plan -i`` asks it (:func:`hbtp.pipeline.instruct.goal_from_instruction`,
its checks and feedback rounds included): its goal must be the label's (the same disjuncts of the
same literals), and an instruction about what the world lacks must be refused.

The model runs in a process of its own (:func:`evaluate_in_child`): torch, which trained it, and
llama.cpp each bring an OpenMP runtime, and one process should hold one.
"""

from __future__ import annotations

import json
import logging
import multiprocessing
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from hbtp.domains import Scenario
from hbtp.errors import InputError
from hbtp.llm.backend import Backend, PromptStyle
from hbtp.llm.backends.local import LocalBackend
from hbtp.llm.goal_prompt import refusal_of
from hbtp.llm.parse import parse_reply
from hbtp.llm.pool import example_pool
from hbtp.llm.prompt import PromptOptions, build_request
from hbtp.llm.spelling import Spelling, read_plan
from hbtp.llm.vocabulary import as_names
from hbtp.logic.names import ActionNames
from hbtp.pipeline.instruct import goal_from_instruction
from hbtp.planning import Limits, plan
from hbtp.planning.heuristic_names import HeuristicName
from hbtp.planning.hints import Hints
from hbtp.planning.planners import Space
from hbtp.train.examples import Example, ExampleKind, goal_key

log = logging.getLogger(__name__)

#: Seconds a judging search may take (a loop round's default).
ROUND_SECONDS = 5.0


@dataclass(frozen=True)
class HeldOutScore:
    """The share of held-back goals answered exactly, covered and solved without feedback (NF);
    of held-back instructions read as their goal exactly, and of the refusals among them refused;
    and the model's median seconds per question (an instruction's feedback rounds together)."""

    examples: int
    exact: float
    covered: float
    nf: float
    median_seconds: float
    instructions: int = 0
    instruction_exact: float = 0.0
    refusals: int = 0
    refused: float = 0.0

    def to_dict(self) -> dict[str, float | int]:
        return asdict(self)


def _answer(names: ActionNames, reply: str, filled: tuple[str, ...] = ()) -> Hints:
    """The hints of a taught reply (the plan) with the plan's predicates and objects (Q(p̂), O(p̂)),
    and the ``filled`` predicates (of the actions the adapter leaves to the check: the reply is read
    unchecked, as a world that is not grounded reads it)."""
    return Hints(predicates=filled).grown_by(parse_reply("Optimal Actions:" + reply).hints, names)


def _same_goal(reply: str, goal: str) -> bool:
    try:
        return goal_key(reply) == goal_key(goal)
    except InputError:
        return False


def evaluate(scenario: Scenario, adapter: Path | None, examples: Sequence[Example], threads: int = 2) -> HeldOutScore:
    """Ask every example of the local model (with ``adapter``) as ``--llm local`` would, and judge the answers."""
    backend = LocalBackend(adapter=adapter, threads=threads)
    try:
        return judge(scenario, backend, examples)
    finally:
        backend.close()


def judge(scenario: Scenario, backend: Backend, examples: Sequence[Example]) -> HeldOutScore:
    """Ask ``backend`` every example as ``--llm local`` asks it (a taught backend the short prompt, the
    base model with demonstrations from the world's pool, never of the very goal asked; an
    instruction through :func:`hbtp.pipeline.instruct.goal_from_instruction`, its checks included),
    and judge the answers."""
    names = as_names(scenario.task)
    taught = bool(getattr(backend, "taught", False))
    pool = [] if taught else example_pool(scenario)
    options = PromptOptions(style=PromptStyle.COMPLETION, exclude_same_goal=True).for_backend(
        PromptStyle.COMPLETION, taught, getattr(backend, "spelling", Spelling.UNDERSCORED)
    )
    known = set(names.action_predicates)
    filled = tuple(p for p in getattr(backend, "filled_predicates", ()) if p in known)
    exact = covered = solved = 0
    seconds: list[float] = []
    hints_examples = [e for e in examples if e.kind is ExampleKind.HINTS]
    goal_examples = [e for e in examples if e.kind is ExampleKind.GOAL]
    for example in hints_examples:
        reply = backend.complete(build_request(names, example.goal, pool, options))
        seconds.append(reply.seconds)
        hints, label = _answer(names, reply.text, filled), _answer(names, read_plan(example.reply), filled)
        exact += hints.path == label.path
        covered += set(label.predicates) <= set(hints.predicates) and set(label.objects) <= set(hints.objects)
        result = plan(
            scenario.task, example.goal, "hbtp-s", hints=hints, space=Space.PRUNED, heuristic=HeuristicName.NONE,
            mutexes=scenario.mutexes, limits=Limits(time_s=ROUND_SECONDS),
        )  # fmt: skip
        solved += result.solved
    read, refused = _instructions(scenario, backend, goal_examples, seconds)
    refusals = sum(refusal_of(e.reply) is not None for e in goal_examples)
    count, asked = max(1, len(hints_examples)), max(1, len(goal_examples))
    middle = sorted(seconds)[len(seconds) // 2] if seconds else 0.0
    return HeldOutScore(
        len(hints_examples), exact / count, covered / count, solved / count, round(middle, 3),
        len(goal_examples), (read + refused) / asked, refusals, refused / max(1, refusals),
    )  # fmt: skip


def _instructions(
    scenario: Scenario, backend: Backend, examples: Sequence[Example], seconds: list[float]
) -> tuple[int, int]:
    """How many instruction ``examples`` were read as their goal, and how many of the refusals among
    them were refused, by the model or before it was asked (each asked as ``hbtp plan -i`` asks it;
    the model's seconds for each, its rounds together, added to ``seconds``)."""
    read = refused = 0
    for example in examples:
        instruction = example.prompt.removeprefix("Instruction: ").removesuffix("\nGoals:")
        lacks = refusal_of(example.reply) is not None
        try:
            choice = goal_from_instruction(scenario, instruction, backend)
        except InputError:  # refused before the model is asked: about nothing the world knows
            refused += lacks
            continue
        seconds.append(choice.llm_seconds)
        if lacks:
            refused += choice.lacking is not None
        elif choice.goal is not None:
            read += _same_goal(choice.goal, example.goal)
    return read, refused


def _child(source: dict[str, object], adapter: str | None, examples: list[dict[str, str]], out: str) -> None:
    from hbtp.domains import load_pddl_scenario, load_scenario

    name, pddl = source.get("scenario"), source.get("pddl")
    if isinstance(name, str):
        loaded = load_scenario(name)
    elif isinstance(pddl, list | tuple) and len(pddl) == 2:
        loaded = load_pddl_scenario(str(pddl[0]), str(pddl[1]))
    else:
        raise ValueError(f"no world in {source!r}")
    score = evaluate(loaded, Path(adapter) if adapter else None, [Example.from_dict(e) for e in examples])
    Path(out).write_text(json.dumps(score.to_dict()), encoding="utf-8")


def evaluate_in_child(
    source: dict[str, object], adapter: Path | None, examples: Sequence[Example], work: Path
) -> HeldOutScore:
    """:func:`evaluate` in a fresh process (see the module docstring); ``source`` names the world
    (``{"scenario": name}`` or ``{"pddl": [domain, problem]}``)."""
    out = work / "held_out.json"
    out.unlink(missing_ok=True)
    context = multiprocessing.get_context("spawn")
    payload = [e.to_dict() for e in examples]
    started = time.monotonic()
    child = context.Process(target=_child, args=(source, str(adapter) if adapter else None, payload, str(out)))
    child.start()
    child.join()
    if child.exitcode != 0 or not out.is_file():
        log.warning("the held-out evaluation failed (exit code %s)", child.exitcode)
        nan = float("nan")
        return HeldOutScore(len(examples), nan, nan, nan, time.monotonic() - started, 0, nan, 0, nan)
    data = json.loads(out.read_text(encoding="utf-8"))
    return HeldOutScore(**data)


__all__ = ["ROUND_SECONDS", "HeldOutScore", "evaluate", "evaluate_in_child"]
