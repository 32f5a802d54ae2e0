"""``hbtp view``: one self-contained HTML page that draws a tree and steps through an execution trace.

The page (template, style and script in ``hbtp/bt/data/view.*``, inlined; no server, no network)
shows the tree as a collapsible outline with search and zoom, and, for a trace written by ``hbtp
run --trace``, every tick: the active path (the nodes ticked, each with its status, and the path
from the root to the leaf that decided the tick), the state's true literals, and the disturbances and
re-plans on a timeline, per run.

Tick semantics live in Python only: :func:`view_data` ticks the tree with :func:`hbtp.bt.nodes.tick`
and a visitor from every state of the trace and embeds what it visited; the script only draws. It
also checks that the trace belongs to the tree: every literal and action name must be the task's, and
the status and action the trace records at a tick must be what the tree ticks from that state
(otherwise :class:`~hbtp.errors.InputError` names the first tick that differs).

A trace line ``{"run": i, "replan": {"tick": t, ..., "tree": {...}}}`` (``tree``: a root node in the
form of the ``"root"`` of an hbtp JSON tree file, or such a whole file; absent or ``null`` for a
re-plan that found no tree) marks a re-plan; from tick ``t`` of that run on (the next tick line when ``t`` is not given)
the new tree is ticked and drawn. Output is deterministic: the same inputs give the same bytes.
"""

from __future__ import annotations

import html
import json
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

from hbtp.bt.jsonio import node_from_dict
from hbtp.bt.nodes import Action, Condition, Fallback, Node, NodeStatus, tick
from hbtp.errors import InputError
from hbtp.logic.task import GroundTask, State

#: The page's template, style and script (package data, inlined into every page).
TEMPLATE_FILES = ("view.html", "view.css", "view.js")

STATUS_CODES = {NodeStatus.SUCCESS: 0, NodeStatus.FAILURE: 1, NodeStatus.RUNNING: 2}
_STATUSES = {status.value: status for status in NodeStatus}
_MISMATCH = "the trace does not match the tree"


# ---------------------------------------------------------------- reading a trace
@dataclass
class TraceRun:
    """The lines of one run of a trace: its ticks, re-plans and end line, with their line numbers."""

    number: int
    ticks: list[tuple[int, dict[str, Any]]] = field(default_factory=list)
    #: (line number, the ``replan`` object, how many tick lines of the run came before it)
    replans: list[tuple[int, dict[str, Any], int]] = field(default_factory=list)
    end: dict[str, Any] | None = None


def _integer(value: Any) -> int | None:
    """``value`` if it is an integer (not a bool), else ``None``."""
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def _check_tick(step: dict[str, Any], where: str, previous: int) -> None:
    number = _integer(step.get("tick"))
    if number is None or number <= previous:
        raise InputError(f"{where}: the tick number must be an integer above {previous}, not {number!r}")
    state = step.get("state")
    if not isinstance(state, list) or not all(isinstance(name, str) for name in state):
        raise InputError(f"{where}: a tick needs its state as a list of literal names")
    if step.get("status") not in _STATUSES:
        raise InputError(f"{where}: unknown status {step.get('status')!r} (expected success, failure or running)")
    for key in ("action", "disturbance"):
        if step.get(key) is not None and not isinstance(step.get(key), str):
            raise InputError(f"{where}: {key} must be a string or null")


def read_trace(text: str, source: str = "<trace>") -> list[TraceRun]:
    """The runs of a JSONL trace (``hbtp run --trace``), by their numbers.

    Lines are ticks (``{"run": i, "tick": n, "state": [...], "status": ..., "action": ...,
    "disturbance": ...}``), end lines (``{"run": i, "end": ...}``) and re-plans (``{"run": i,
    "replan": {...}}``); ``run`` is 0 when absent (a trace of one run)."""
    runs: dict[int, TraceRun] = {}
    for line_number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        where = f"{source}:{line_number}"
        try:
            record = json.loads(line)
        except (json.JSONDecodeError, RecursionError):
            record = None
        if not isinstance(record, dict):
            raise InputError(f"{where}: not a JSON object (a trace has one per line, as hbtp run --trace writes)")
        number = _integer(record.get("run", 0))
        if number is None:
            raise InputError(f"{where}: run must be an integer, not {record.get('run')!r}")
        run = runs.setdefault(number, TraceRun(number))
        if "replan" in record:
            if not isinstance(record["replan"], dict):
                raise InputError(f"{where}: replan must be an object")
            tick = record["replan"].get("tick")
            if tick is not None and (_integer(tick) is None or tick < 1):
                raise InputError(f"{where}: replan.tick must be a whole number of at least 1, not {tick!r}")
            run.replans.append((line_number, record["replan"], len(run.ticks)))
        elif "end" in record:
            run.end = record
        elif "tick" in record:
            _check_tick(record, where, run.ticks[-1][1]["tick"] if run.ticks else 0)
            run.ticks.append((line_number, record))
        else:
            raise InputError(f"{where}: neither a tick, an end nor a replan line")
    if not any(run.ticks for run in runs.values()):
        raise InputError(f"{source}: no tick lines (write a trace with hbtp run --trace FILE)")
    return [runs[number] for number in sorted(runs)]


# ---------------------------------------------------------------- the trees
@dataclass(frozen=True)
class Layout:
    """A tree's nodes in preorder (a node's id is its position), with parents and children."""

    nodes: tuple[Node, ...]
    parents: tuple[int, ...]
    children: tuple[tuple[int, ...], ...]


def layout(root: Node) -> Layout:
    """The preorder layout of ``root`` (shared subtrees get one id per position)."""
    nodes: list[Node] = []
    parents: list[int] = []
    children: list[list[int]] = []
    stack: list[tuple[Node, int]] = [(root, -1)]
    while stack:
        node, parent = stack.pop()
        position = len(nodes)
        nodes.append(node)
        parents.append(parent)
        children.append([])
        if parent >= 0:
            children[parent].append(position)
        if not isinstance(node, Condition | Action):
            stack.extend((child, position) for child in reversed(node.children))
    return Layout(tuple(nodes), tuple(parents), tuple(tuple(c) for c in children))


def node_label(node: Node, task: GroundTask) -> str:
    """What the page shows for a node: a condition's literals, an action's name, else nothing."""
    if isinstance(node, Condition):
        return " & ".join(task.names(node.literals)) or "true"
    if isinstance(node, Action):
        return task.actions[node.action].name
    return ""


def _kind(node: Node) -> str:
    if isinstance(node, Condition):
        return "C"
    if isinstance(node, Action):
        return "A"
    return "F" if isinstance(node, Fallback) else "S"


def tree_record(tree: Layout, task: GroundTask) -> dict[str, Any]:
    """A tree as the page reads it: ``[kind, label, parent]`` per node, in preorder."""
    nodes = [
        [_kind(node), node_label(node, task), parent] for node, parent in zip(tree.nodes, tree.parents, strict=True)
    ]
    return {"nodes": nodes}


@dataclass(frozen=True)
class Visit:
    """One tick of a tree in a state: its status and action, the nodes ticked (ids with their
    statuses, children before parents) and the active path (root to the leaf that decided it)."""

    status: NodeStatus
    action: int | None
    ticked: tuple[tuple[int, NodeStatus], ...]
    path: tuple[int, ...]

    def to_dict(self) -> dict[str, Any]:
        flat = [value for position, status in self.ticked for value in (position, STATUS_CODES[status])]
        return {"ticked": flat, "path": list(self.path)}


def visit(tree: Layout, state: State, task: GroundTask) -> Visit:
    """Tick ``tree`` in ``state`` with :func:`~hbtp.bt.nodes.tick`, recording the nodes it ticks."""
    record: list[tuple[Node, NodeStatus]] = []
    status, action = tick(tree.nodes[0], state, task, lambda node, result: record.append((node, result)))
    ticked: list[tuple[int, NodeStatus]] = []
    cursor = 0

    def match(position: int) -> None:
        # The visitor reports children before their parent; a parent reported next ends its children.
        nonlocal cursor
        node = tree.nodes[position]
        for child in tree.children[position]:
            if record[cursor][0] is node:
                break
            match(child)
        reported, result = record[cursor]
        if reported is not node:  # pragma: no cover - tick visits the children in order
            raise AssertionError("the visitor's order does not follow the tree")
        ticked.append((position, result))
        cursor += 1

    match(0)
    leaf = next(p for p, _ in reversed(ticked) if not tree.children[p])
    path = [leaf]
    while tree.parents[path[-1]] >= 0:
        path.append(tree.parents[path[-1]])
    return Visit(status, action, tuple(ticked), tuple(reversed(path)))


# ---------------------------------------------------------------- the page's data
@dataclass(frozen=True)
class PlacedReplan:
    """A re-plan of a run: the tick from which it counts, its record for the page, its tree's index."""

    tick: int
    record: dict[str, Any]
    tree: int | None


class _ViewBuilder:
    """Collects the page's tables: trees, literal names, states and visits (each stored once)."""

    def __init__(self, task: GroundTask, source: str) -> None:
        self.task = task
        self.source = source
        self.layouts: list[Layout] = []
        self.trees: dict[Node, int] = {}
        self.names: dict[str, int] = {}
        self.atom_ids: dict[str, int] = {}
        self.states: dict[tuple[int, ...], int] = {}
        self.visits: dict[tuple[int, State], tuple[Visit, int]] = {}

    def tree(self, root: Node) -> int:
        if root not in self.trees:
            self.trees[root] = len(self.layouts)
            self.layouts.append(layout(root))
        return self.trees[root]

    def state(self, names: Sequence[str], where: str) -> tuple[State, int]:
        """The state's atom ids and its index in the page's state table."""
        ids: set[int] = set()
        for name in names:
            if name not in self.atom_ids:
                try:
                    self.atom_ids[name] = self.task.atom_id(name)
                except InputError as error:
                    raise InputError(f"{where}: {error}: {_MISMATCH}") from None
            ids.add(self.atom_ids[name])
        key = tuple(self.names.setdefault(name, len(self.names)) for name in names)
        return frozenset(ids), self.states.setdefault(key, len(self.states))

    def visit(self, tree: int, state: State) -> tuple[Visit, int]:
        key = (tree, state)
        if key not in self.visits:
            self.visits[key] = (visit(self.layouts[tree], state, self.task), len(self.visits))
        return self.visits[key]

    def replans(self, run: TraceRun) -> list[PlacedReplan]:
        """The run's re-plans, each with the tick from which it counts, in that order (then file order)."""
        placed: list[PlacedReplan] = []
        for line, replan, before in run.replans:
            where = f"{self.source}:{line}"
            number = _integer(replan.get("tick"))
            if number is None:  # the next tick line's
                number = run.ticks[before][1]["tick"] if before < len(run.ticks) else 1 << 62
            tree, given = None, replan.get("tree")
            if isinstance(given, dict) and "root" in given and "type" not in given:
                given = given["root"]  # a whole hbtp-tree document
            if given is not None:
                try:
                    tree = self.tree(node_from_dict(given, self.task, "replan.tree"))
                except InputError as error:
                    raise InputError(f"{where}: {error}") from None
            record = {key: replan.get(key) for key in ("tick", "reason", "seconds", "status", "cost", "message")}
            placed.append(PlacedReplan(number, {**record, "tree": tree, "line": line}, tree))
        return sorted(placed, key=lambda r: r.tick)

    def check(self, step: dict[str, Any], found: Visit, where: str) -> None:
        """The trace's status and action at a tick must be the tree's."""
        said: str | None = step["action"]
        said_index = None
        if said is not None:
            try:
                said_index = self.task.action(said).index
            except InputError as error:
                raise InputError(f"{where}: {error}: {_MISMATCH}") from None
        ticked = self.task.actions[found.action].name if found.action is not None else None
        if (_STATUSES[step["status"]], said_index) != (found.status, found.action):
            raise InputError(
                f"{where}: the trace says {_outcome(step['status'], said)} but the tree ticks "
                f"{_outcome(found.status.value, ticked)} from that state: {_MISMATCH}"
            )

    def run(self, run: TraceRun, initial: int) -> dict[str, Any]:
        """The page's record of one run: its ticks (each with its tree, state and visit) and re-plans."""
        pending = self.replans(run)
        records = [replan.record for replan in pending]
        current, next_replan, ticks = initial, 0, []
        for line, step in run.ticks:
            number = step["tick"]
            marks = []
            while next_replan < len(pending) and pending[next_replan].tick <= number:
                tree = pending[next_replan].tree
                current = current if tree is None else tree
                marks.append(next_replan)
                next_replan += 1
            where = f"{self.source}:{line}: run {run.number}, tick {number}"
            state, state_index = self.state(step["state"], where)
            found, visit_index = self.visit(current, state)
            self.check(step, found, where)
            ticks.append(
                {"tick": number, "tree": current, "state": state_index, "visit": visit_index,
                 "status": step["status"], "action": step["action"], "disturbance": step.get("disturbance"),
                 "replans": marks}
            )  # fmt: skip
        if next_replan < len(pending) and ticks:  # re-plans after the last tick mark that tick
            ticks[-1]["replans"].extend(range(next_replan, len(pending)))
        return {"run": run.number, "label": _run_label(run), "ticks": ticks, "replans": records}


def _outcome(status: str, action: str | None) -> str:
    return f"{status} {action}" if action else status


def _run_label(run: TraceRun) -> str:
    text = f"run {run.number}"
    end = run.end
    if end is None:
        return f"{text}: {len(run.ticks)} tick(s), no end line"
    parts = [str(end.get("end")), f"{end.get('ticks', len(run.ticks))} tick(s)"]
    if end.get("cost") is not None:
        parts.append(f"cost {end.get('cost')}")
    if end.get("events"):
        parts.append(f"{end.get('events')} event(s)")
    if run.replans:
        parts.append(f"{len(run.replans)} re-plan(s)")
    return f"{text}: " + ", ".join(parts)


@dataclass(frozen=True)
class ViewHeader:
    """What the page's heading says: the tree file, its scenario and goal, the trace file."""

    title: str = "behavior tree"
    scenario: str = ""
    goal: str = ""
    trace: str | None = None


def view_data(
    tree: Node,
    task: GroundTask,
    runs: Sequence[TraceRun] = (),
    header: ViewHeader = ViewHeader(),
    source: str | None = None,
) -> dict[str, Any]:
    """Everything the page shows, as one JSON-ready object (see the module docstring); ``source``
    names the trace in error messages (default: ``header.trace``)."""
    builder = _ViewBuilder(task, source or header.trace or "<trace>")
    initial = builder.tree(tree)
    run_records = [builder.run(run, initial) for run in runs]
    visits = sorted(builder.visits.values(), key=lambda entry: entry[1])
    return {
        "format": "hbtp-view",
        "version": 1,
        "title": header.title,
        "scenario": header.scenario or task.name,
        "goal": header.goal,
        "trace": header.trace,
        "trees": [tree_record(item, task) for item in builder.layouts],
        "names": list(builder.names),
        "states": [list(key) for key in builder.states],
        "visits": [found.to_dict() for found, _ in visits],
        "runs": run_records,
    }


# ---------------------------------------------------------------- the page
def _template(name: str) -> str:
    return (resources.files("hbtp.bt") / "data" / name).read_text(encoding="utf-8")


def script_json(data: Any) -> str:
    """``data`` as JSON that is safe inside ``<script type="application/json">`` (no ``<`` at all,
    so neither ``</script>`` nor ``<!--`` can end or change the element)."""
    text = json.dumps(data, ensure_ascii=False, separators=(",", ":"))
    return text.replace("<", "\\u003c").replace("\u2028", "\\u2028").replace("\u2029", "\\u2029")


def render_page(data: dict[str, Any]) -> str:
    """The self-contained HTML page of :func:`view_data`'s ``data``."""
    page, style, script = (_template(name) for name in TEMPLATE_FILES)
    values = {
        "title": html.escape(f"{data['title']} - hbtp view"),
        "style": style,
        "script": script,
        "data": script_json(data),
    }
    return re.sub(r"\{\{(title|style|script|data)\}\}", lambda match: values[match.group(1)], page)


def tree_page(tree: Node, task: GroundTask, trace_text: str | None = None, header: ViewHeader = ViewHeader()) -> str:
    """The HTML page of ``tree`` and, if given, the JSONL trace ``trace_text`` (read as ``header.trace``)."""
    runs = read_trace(trace_text, header.trace or "<trace>") if trace_text is not None else []
    return render_page(view_data(tree, task, runs, header))


__all__ = [
    "Layout",
    "TraceRun",
    "ViewHeader",
    "Visit",
    "layout",
    "read_trace",
    "render_page",
    "script_json",
    "tree_page",
    "view_data",
    "visit",
]
