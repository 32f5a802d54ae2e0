"""A taught plan spelled with spaces (``Walk milk``): written, constrained and read back exactly,
in the shipped worlds and in a PDDL world whose names hold underscores."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from hbtp.domains import Scenario, load_scenario
from hbtp.domains.scenarios import load_pddl_scenario
from hbtp.llm.backend import PromptStyle, Reply, Request
from hbtp.llm.backends.replay import RecordingBackend, ReplayBackend
from hbtp.llm.checked import checked_answer
from hbtp.llm.constrain import constraint_of
from hbtp.llm.prompt import PromptOptions, build_request
from hbtp.llm.spelling import Spelling, read_plan
from hbtp.llm.vocabulary import as_names

IPC = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "ipc"
CHILDSNACK = IPC / "childsnack-opt14-strips"


def _worlds() -> list[Scenario]:
    worlds = [load_scenario(name) for name in ("robowaiter", "virtualhome", "robothow-small")]
    if CHILDSNACK.is_dir():  # make_sandwich_no_gluten: a predicate with underscores of its own
        worlds.append(load_pddl_scenario(CHILDSNACK / "domain.pddl", CHILDSNACK / "child-snack_pfile01.pddl"))
    return worlds


@pytest.mark.parametrize("world", _worlds(), ids=lambda world: world.name)
def test_every_action_spelled_with_spaces_reads_back_as_itself(world: Scenario) -> None:
    actions = [action.signature for action in world.task.actions]
    spaced = Spelling.SPACED.plan(actions) + "\n\n"
    assert read_plan(spaced) == " " + ", ".join(a.underscored for a in actions) + "\n\n"
    assert read_plan(Spelling.UNDERSCORED.plan(actions)) == Spelling.UNDERSCORED.plan(actions)  # nothing to undo
    for action, name in zip(world.task.actions, read_plan(spaced).strip().split(", "), strict=True):
        assert world.task.action(name) is action


@pytest.mark.parametrize("world", _worlds(), ids=lambda world: world.name)
def test_the_spaced_grammar_admits_exactly_the_spaced_names(world: Scenario) -> None:
    names = as_names(world.task)
    constraint = constraint_of(names, path_only=True, spelling=Spelling.SPACED)
    pattern = re.compile(constraint.schema["properties"]["optimal_actions"]["items"]["pattern"])
    spaced = {Spelling.SPACED.write(a) for a in names.actions}
    assert all(pattern.match(name) for name in spaced)
    assert not any(pattern.match(a.underscored) for a in names.actions if a.args)
    assert '"_"' not in constraint.gbnf
    # the underscored grammar is as it was: its names, not the spaced ones
    underscored = re.compile(constraint_of(names).schema["properties"]["optimal_actions"]["items"]["pattern"])
    assert all(underscored.match(a.underscored) for a in names.actions)
    assert not any(underscored.match(name) for name in spaced if " " in name)


class SpacedModel:
    """A taught model that writes spaced plans, given back in the datasets' spelling, as the local
    backend gives them (a scripted stand-in for an adapter of prompt format 3)."""

    name = "spaced"
    prompt_style = PromptStyle.COMPLETION
    taught = True
    spelling = Spelling.SPACED

    def __init__(self, answers: dict[str, str]) -> None:
        self.answers = answers
        self.asked: list[Request] = []

    def complete(self, request: Request) -> Reply:
        self.asked.append(request)
        text = next(reply for ending, reply in self.answers.items() if request.completion_prompt.endswith(ending))
        return Reply(read_plan(text), seconds=0.01)

    def close(self) -> None:
        pass


def test_a_continued_plan_is_asked_in_the_spelling_of_the_model(robowaiter: Scenario) -> None:
    goal = "On_Coffee_Table3"
    rest = " MoveTo Coffee, PickUp Coffee, MoveTo Table3, PutDown Coffee Table3\n\n"
    model = SpacedModel({"Make Coffee,": rest, "Optimal Actions:": " Make Coffee\n\n"})
    options = PromptOptions(style=PromptStyle.COMPLETION).for_backend(PromptStyle.COMPLETION, True, model.spelling)
    request = build_request(as_names(robowaiter.task), goal, [], options)
    assert request.spelling is Spelling.SPACED
    answer = checked_answer(model.complete, request, robowaiter.task, robowaiter.task.resolve_goal(goal))
    assert answer.reached
    assert answer.plan == ("Make_Coffee", "MoveTo_Coffee", "PickUp_Coffee", "MoveTo_Table3", "PutDown_Coffee_Table3")
    first, second = model.asked
    assert second.completion_prompt == first.completion_prompt + " Make Coffee,"
    assert second.constraint is not None
    offered = re.search(r"^first ::= (.*)$", second.constraint.gbnf, re.M)
    assert offered is not None
    assert '"MoveTo Coffee"' in offered.group(1)
    assert "_" not in offered.group(1)


def test_a_spaced_recording_replays_with_its_spelling(robowaiter: Scenario, tmp_path: Path) -> None:
    goal = "On_Coffee_Table3"
    answers = {"Make Coffee,": " MoveTo Coffee, PickUp Coffee, MoveTo Table3, PutDown Coffee Table3\n\n",
               "Optimal Actions:": " Make Coffee\n\n"}  # fmt: skip
    record = tmp_path / "spaced.jsonl"
    recorder = RecordingBackend(SpacedModel(answers), record)  # type: ignore[arg-type]
    assert recorder.spelling is Spelling.SPACED
    options = PromptOptions(style=PromptStyle.COMPLETION).for_backend(PromptStyle.COMPLETION, True, recorder.spelling)
    request = build_request(as_names(robowaiter.task), goal, [], options)
    recorded = checked_answer(recorder.complete, request, robowaiter.task, robowaiter.task.resolve_goal(goal))
    replay = ReplayBackend(record)
    assert replay.taught
    assert replay.spelling is Spelling.SPACED
    replayed = checked_answer(replay.complete, request, robowaiter.task, robowaiter.task.resolve_goal(goal))
    assert replayed.plan == recorded.plan
    assert replayed.reached
