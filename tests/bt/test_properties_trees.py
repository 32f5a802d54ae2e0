"""Properties of the tree files (hbtp.bt.jsonio, hbtp.bt.btcpp, hbtp.bt.treefile), on generated
tasks, trees and goals.

A generated task has predicates, action predicates and objects named in every way hbtp accepts
(``_`` and ``-`` in names, 0-ary predicates, names of BehaviorTree.CPP's own nodes, an action
predicate that is also a condition predicate), some negated twins, and a tree of any shape over
it (empty and negated conditions, a group or a lone leaf at the root, nested groups). Written as
hbtp JSON or as BehaviorTree.CPP XML (every writer option) and read back through
:func:`~hbtp.bt.treefile.read_tree_file`, the tree is the same tree and the recorded scenario and
goal resolve to the same goal.

The hand-picked edge shapes (tests/helpers.py ``edge_shape_trees``) and planned trees cover the
shapes someone thought of; Hypothesis combines names and shapes and shrinks a tree that does not
read back to the smallest one.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hbtp.bt import Action, Condition, Fallback, Node, Sequence
from hbtp.bt.btcpp import tree_to_btcpp
from hbtp.bt.jsonio import goal_text, tree_to_json
from hbtp.bt.treefile import read_tree_file
from hbtp.domains import DomainBuilder
from hbtp.logic.goal import Goal
from hbtp.logic.negation import with_negations
from hbtp.logic.task import GroundTask

PROPERTY = settings(max_examples=100, deadline=None, derandomize=True)

#: Names that need care (BT.CPP's node IDs, a name a clash is renamed to, '_', '-' and '--', which the
#: XML's leading comment, recording the scenario and goal, escapes), and any other.
NAMES = st.one_of(
    st.sampled_from(["Open", "Open_condition", "Sleep", "Sleep_action", "Condition", "root", "have_image", "is--on"]),
    st.from_regex(r"[A-Za-z][A-Za-z0-9_\-]{0,5}", fullmatch=True),
)


@st.composite
def tasks(draw: st.DrawFn) -> GroundTask:
    """A small task: its atoms hold in s0 or are touched by an action; some have negated twins."""
    names = draw(st.lists(NAMES, min_size=4, max_size=7, unique_by=str.lower))
    objects, names = names[:2], names[2:]
    predicates = {name: draw(st.integers(0, 2)) for name in names[: draw(st.integers(1, len(names) - 1))]}
    grounded = st.lists(st.sampled_from(objects), min_size=0, max_size=2)
    atoms = sorted(
        {
            f"{name}({','.join(draw(st.lists(st.sampled_from(objects), min_size=arity, max_size=arity)))})"
            for name, arity in predicates.items()
            for _ in range(draw(st.integers(1, 2)))
        }
    )
    # action predicates: new names, or the name of a condition predicate (a clash the BT.CPP IDs resolve)
    signatures = {
        f"{name}({','.join(draw(grounded))})"
        for name in draw(st.lists(st.sampled_from(names), min_size=1, max_size=3, unique=True))
    }
    subsets = st.lists(st.sampled_from(atoms), max_size=2, unique=True)
    builder = DomainBuilder(draw(NAMES))
    for signature in sorted(signatures):
        builder.action(signature, pre=draw(subsets), add=draw(subsets), delete=draw(subsets), cost=1)
    builder.initial(draw(st.lists(st.sampled_from(atoms), min_size=1, unique=True)))
    base = builder.build()
    twinned = draw(st.lists(st.sampled_from(range(len(base.atoms))), max_size=3, unique=True))
    return with_negations(base, twinned)


def trees(task: GroundTask) -> st.SearchStrategy[Node]:
    """Trees of any shape over ``task``: conditions of 0-3 literals (negated twins included), actions,
    and Sequence and Fallback nodes of 1-3 children."""
    literals = st.sampled_from(range(len(task.atoms)))
    leaves = st.one_of(
        st.builds(Condition, st.frozensets(literals, max_size=3)),
        st.builds(Action, st.sampled_from(range(len(task.actions)))),
    )
    return st.recursive(
        leaves,
        lambda inner: st.one_of(
            st.builds(Sequence, st.lists(inner, min_size=1, max_size=3).map(tuple)),
            st.builds(Fallback, st.lists(inner, min_size=1, max_size=3).map(tuple)),
        ),
        max_leaves=12,
    )


def goals(task: GroundTask) -> st.SearchStrategy[Goal]:
    """A goal of 1-3 terms of 1-3 literals (``~p`` where ``p`` has a twin), resolved against ``task``."""
    negatable = [task.atoms[i].negate() for i in task.negation_ids]
    literals = st.sampled_from([atom for atom in task.atoms if not atom.negated] + negatable)
    terms = st.lists(st.lists(literals, min_size=1, max_size=3), min_size=1, max_size=3)
    return terms.map(lambda chosen: task.resolve_goal(" | ".join(" & ".join(map(str, t)) for t in chosen)))


@st.composite
def cases(draw: st.DrawFn) -> tuple[GroundTask, Node, Goal]:
    task = draw(tasks())
    return task, draw(trees(task)), draw(goals(task))


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("trees")


def _read_back(path: Path, text: str, task: GroundTask, goal: Goal) -> Node:
    """The tree of the file ``text`` written at ``path``, its recorded scenario and goal checked."""
    path.write_text(text, encoding="utf-8")
    read = read_tree_file(path)
    assert read.scenario == task.name, text
    again = read.resolve_goal(task)
    assert again is not None, text
    assert again.terms == goal.terms, text
    assert again.disjuncts == goal.disjuncts, text
    return read.tree(task)


@PROPERTY
@given(case=cases())
def test_a_tree_written_as_json_reads_back_equal(case: tuple[GroundTask, Node, Goal], folder: Path) -> None:
    task, tree, goal = case
    text = tree_to_json(tree, task, scenario=task.name, goal=goal)
    assert _read_back(folder / "tree.json", text, task, goal) == tree, text


@PROPERTY
@given(case=cases(), reactive=st.booleans(), ports=st.booleans(), explicit_leaves=st.booleans())
def test_a_tree_written_as_btcpp_xml_reads_back_equal(
    case: tuple[GroundTask, Node, Goal], reactive: bool, ports: bool, explicit_leaves: bool, folder: Path
) -> None:
    task, tree, goal = case
    text = tree_to_btcpp(
        tree,
        task,
        scenario=task.name,
        goal=goal_text(goal),
        reactive=reactive,
        ports=ports,
        explicit_leaves=explicit_leaves and not reactive,  # BT.CPP 4.8 rejects them under reactive nodes
    )
    assert _read_back(folder / "tree.xml", text, task, goal) == tree, text
