"""BehaviorTree.CPP v4 XML: a writer Groot2 opens and BehaviorTree.CPP 4.x loads, and a reader back.

Mapping (one node ID per predicate, grounded arguments as input ports)::

    <root BTCPP_format="4" main_tree_to_execute="MainTree">
      <BehaviorTree ID="MainTree">
        <ReactiveFallback>
          <Sequence name="Condition 1">                     <!-- a Condition of several literals -->
            <IsClose name="IsClose(fridge)" arg1="fridge"/>
            <IsIn name="IsIn(apple,fridge)" arg1="apple" arg2="fridge"/>
          </Sequence>
          <ReactiveSequence name="Sequence 2">
            <IsOpen name="IsOpen(fridge)" arg1="fridge"/>   <!-- a single literal: the leaf itself -->
            <RightPutIn name="RightPutIn(apple,fridge)" arg1="apple" arg2="fridge"/>
          </ReactiveSequence>
        </ReactiveFallback>
      </BehaviorTree>
      <TreeNodesModel>
        <Action ID="RightPutIn"><input_port name="arg1" type="std::string"/>...</Action>
        <Condition ID="IsIn">...</Condition>
      </TreeNodesModel>
    </root>

* **One node ID per predicate and per action predicate** (``IsIn``, ``RightPutIn``), the grounded
  objects as string input ports ``arg1..argN``: the robot implements one C++ class per predicate
  (about twenty for RobotHow) instead of one per grounded literal (thousands), and Groot2 shows the
  arguments as editable ports. The instance ``name`` repeats the grounded literal (``IsIn(apple,
  fridge)``) so that Groot2's boxes and BT.CPP's loggers read like the planner's output.
* **A negated literal ``~P(a)`` is an ``Inverter`` over the condition leaf of ``P(a)``**, named
  ``~P(a)`` (see :mod:`hbtp.logic.negation`); the reader takes such an Inverter back as the literal.
* **A Condition of several literals is a ``Sequence`` of single-literal conditions** named
  ``Condition N``: each literal stays a reusable predicate check, and Groot2's live monitor shows
  *which* literal failed, which a single node with a list-valued port would hide. The reader folds
  such a ``Sequence`` (named ``Condition`` or ``Condition N``) back into one Condition; the empty
  Condition is ``<AlwaysSuccess>``.
* **Every group and control node but the root is named after its kind and its position among its
  siblings** (``Condition 1``, ``Sequence 3``, ``Fallback 2``; a group at the root is ``Condition``),
  so that the path of names from the root to any node is unique: py_trees' BT.CPP-XML reader
  (``py_trees.parsers.behaviour_tree_xml``) names each node by that path and rejects a tree with two
  equal names.
* **Reactive control nodes** (``ReactiveFallback``, ``ReactiveSequence``, the default): the planner's
  trees re-check the goal and every condition at each tick (our :func:`hbtp.bt.nodes.tick` restarts at
  the root), which is exactly what BT.CPP's reactive nodes do while an asynchronous action is
  RUNNING. The plain ``Sequence``/``Fallback`` resume a RUNNING child without re-checking the
  conditions before it; ask for them with ``reactive=False``.
* **Compact leaves** (``<IsIn .../>``, the form Groot2 writes) by default. The explicit form
  (``<Condition ID="IsIn" .../>``) is available with ``explicit_leaves=True``, but BehaviorTree.CPP
  4.8.2 (the one inside behaviortreepy 0.1.4) rejects explicit leaves placed directly under a
  ``ReactiveSequence`` ("Unknown node type: Condition": the ReactiveSequence check added in late 2024
  looks children up by element name), so use it with ``reactive=False``.
* IDs that would clash (a predicate and an action predicate with the same name, or a BT.CPP built-in
  such as ``Sleep`` or ``Delay``) get a ``_condition``/``_action`` suffix; the reader derives the same
  table from the task, so the mapping is a pure function of the task.

``ports=False`` drops the ports (leaves keep their grounded ``name``), for runtimes whose simple
nodes cannot declare ports: BT.CPP rejects a port attribute that the registered node type does not
declare, and ``behaviortreepy`` 0.1.4 registers Python callbacks with no ports at all.
"""

from __future__ import annotations

import logging
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from dataclasses import dataclass

from hbtp.bt.nodes import MAX_TREE_DEPTH, MAX_TREE_NODES, Action, Condition, Fallback, Node, Sequence, walk
from hbtp.errors import InputError
from hbtp.logic.atoms import Atom, parse_atom
from hbtp.logic.task import GroundTask

logger = logging.getLogger(__name__)

BTCPP_FORMAT = "4"
CONDITION_GROUP = "Condition"
"""The ``name`` of a Sequence that stands for one Condition of several literals."""

# Node IDs that BehaviorTree.CPP 4.x registers itself, and the XML element names of its format:
# a domain predicate or action with one of these names gets a suffixed ID.
BUILTIN_IDS = frozenset(
    {
        "Action", "AlwaysFailure", "AlwaysSuccess", "BehaviorTree", "Condition", "Control", "Decorator",
        "Delay", "Fallback", "ForceFailure", "ForceSuccess", "IfThenElse", "Inverter",
        "KeepRunningUntilFailure", "LoopBool", "LoopDouble", "LoopInt", "LoopString", "ManualSelector",
        "Parallel", "ParallelAll", "PopFromQueue", "Precondition", "ReactiveFallback", "ReactiveSequence",
        "Repeat", "RetryUntilSuccessful", "RunOnce", "Script", "ScriptCondition", "Sequence",
        "SequenceWithMemory", "SetBlackboard", "SkipUnlessUpdated", "Sleep", "SubTree", "SubTreePlus",
        "Switch2", "Switch3", "Switch4", "Switch5", "Switch6", "Timeout", "TreeNodesModel", "TryCatch",
        "UnsetBlackboard", "WaitValueUpdate", "WasEntryUpdated", "WhileDoElse", "include", "root",
    }
)  # fmt: skip

_SEQUENCES = {"Sequence": False, "ReactiveSequence": True}
_FALLBACKS = {"Fallback": False, "ReactiveFallback": True}
_UNSUPPORTED_CONTROLS = {
    "SequenceWithMemory": "it keeps its position between ticks; hbtp trees restart at the root",
    "Parallel": "hbtp trees have no parallel node",
    "ParallelAll": "hbtp trees have no parallel node",
}
_ARG_PORT = re.compile(r"arg([1-9][0-9]*)")
_XML_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")
# The name of a Sequence that stands for one Condition: ``Condition 2`` (``Condition`` in files
# written before groups were numbered).
_GROUP_NAME = re.compile(re.escape(CONDITION_GROUP) + r"(?: [0-9]+)?")
# Attributes that only inform (Groot2 and BT.CPP write them) and never change what a node does.
_INFORMATIVE = frozenset({"name", "ID", "_description", "_uid", "_fullpath"})


@dataclass(frozen=True)
class NodeIds:
    """The BT.CPP node IDs of a task: predicate -> condition ID, action predicate -> action ID."""

    conditions: dict[str, str]
    actions: dict[str, str]

    @property
    def condition_predicates(self) -> dict[str, str]:
        """Condition ID -> predicate."""
        return {node_id: predicate for predicate, node_id in self.conditions.items()}

    @property
    def action_predicates(self) -> dict[str, str]:
        """Action ID -> action predicate."""
        return {node_id: predicate for predicate, node_id in self.actions.items()}


def node_ids(task: GroundTask) -> NodeIds:
    """The node ID of every predicate and action predicate of ``task`` (deterministic, collision-free)."""
    predicates = sorted(set(task.predicates) | {atom.predicate for atom in task.atoms})
    action_predicates = sorted(set(task.action_predicates))
    taken = set(BUILTIN_IDS)
    conditions: dict[str, str] = {}
    actions: dict[str, str] = {}
    clashing_predicates = {p for p in predicates if p in BUILTIN_IDS or p in action_predicates}
    clashing_actions = {a for a in action_predicates if a in BUILTIN_IDS}
    for predicate in predicates:
        if predicate not in clashing_predicates:
            conditions[predicate] = predicate
            taken.add(predicate)
    for predicate in action_predicates:
        if predicate not in clashing_actions:
            actions[predicate] = predicate
            taken.add(predicate)
    for table, names, suffix in (
        (conditions, clashing_predicates, "_condition"),
        (actions, clashing_actions, "_action"),
    ):
        for name in sorted(names):
            candidate = name + suffix
            while candidate in taken:
                candidate += "_"
            table[name] = candidate
            taken.add(candidate)
            logger.info("BT.CPP node ID %r stands for %r (the name clashes)", candidate, name)
    return NodeIds(conditions, actions)


# ---------------------------------------------------------------------------------------------- writer


def tree_to_btcpp(
    tree: Node,
    task: GroundTask,
    *,
    tree_id: str = "MainTree",
    scenario: str = "",
    goal: str = "",
    reactive: bool = True,
    ports: bool = True,
    explicit_leaves: bool = False,
) -> str:
    """The tree as a BehaviorTree.CPP v4 XML document (deterministic: same tree, same text).

    ``scenario`` and ``goal`` go into a leading comment (``generated by hbtp for scenario NAME, goal
    GOAL``, read back by :func:`btcpp_metadata`; give the goal in the ``Pred(a,b)`` form). See the
    module docstring for the mapping and for ``reactive``, ``ports`` and ``explicit_leaves``.
    """
    if explicit_leaves and reactive:
        logger.warning("BehaviorTree.CPP 4.8 rejects explicit <Condition ID=...> leaves under a ReactiveSequence")
    writer = _Writer(task, reactive=reactive, ports=ports, explicit_leaves=explicit_leaves)
    root = ET.Element("root", {"BTCPP_format": BTCPP_FORMAT, "main_tree_to_execute": tree_id})
    about = "generated by hbtp" + (f" for scenario {scenario}" if scenario else "") + (f", goal {goal}" if goal else "")
    root.append(ET.Comment(" " + _comment_text(about) + " "))
    behavior_tree = ET.SubElement(root, "BehaviorTree", {"ID": tree_id})
    behavior_tree.append(writer.node(tree))
    root.append(writer.model())
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


class _Writer:
    """Builds the elements of one tree and records the node IDs it uses, with their port counts."""

    def __init__(self, task: GroundTask, *, reactive: bool, ports: bool, explicit_leaves: bool) -> None:
        self.task = task
        self.ids = node_ids(task)
        self.reactive = reactive
        self.ports = ports
        self.explicit_leaves = explicit_leaves
        self.used: dict[str, dict[str, int]] = {"Action": {}, "Condition": {}}  # kind -> ID -> ports

    def node(self, node: Node, position: int = 0) -> ET.Element:
        """The element of ``node``, the ``position``-th child of its parent (0: the root)."""
        task = self.task
        if isinstance(node, Condition):
            atoms = sorted(task.atoms[i] for i in node.literals)
            if not atoms:
                return ET.Element("AlwaysSuccess", _named(CONDITION_GROUP, position, root=CONDITION_GROUP))
            leaves = [self.literal(a) for a in atoms]
            if len(leaves) == 1:
                return leaves[0]
            group = ET.Element("Sequence", _named(CONDITION_GROUP, position, root=CONDITION_GROUP))
            group.extend(leaves)
            return group
        if isinstance(node, Action):
            signature = task.actions[node.action].signature
            return self.leaf("Action", self.ids.actions[signature.predicate], signature)
        if isinstance(node, Sequence):
            element = ET.Element("ReactiveSequence" if self.reactive else "Sequence", _named("Sequence", position))
        else:
            element = ET.Element("ReactiveFallback" if self.reactive else "Fallback", _named("Fallback", position))
        element.extend(self.node(child, index) for index, child in enumerate(node.children, start=1))
        return element

    def literal(self, atom: Atom) -> ET.Element:
        """The check of one literal: its condition leaf, under an ``Inverter`` when negated."""
        leaf = self.leaf("Condition", self.ids.conditions[atom.predicate], atom.positive)
        if not atom.negated:
            return leaf
        inverter = ET.Element("Inverter", {"name": str(atom)})
        inverter.append(leaf)
        return inverter

    def leaf(self, kind: str, node_id: str, atom: Atom) -> ET.Element:
        if self.explicit_leaves or not _XML_NAME.fullmatch(node_id):
            element = ET.Element(kind, {"ID": node_id, "name": str(atom)})
        else:
            element = ET.Element(node_id, {"name": str(atom)})
        if self.ports:
            for position, value in enumerate(atom.args, start=1):
                element.set(f"arg{position}", value)
        used = self.used[kind]
        used[node_id] = max(used.get(node_id, 0), len(atom.args))
        return element

    def model(self) -> ET.Element:
        """The ``<TreeNodesModel>`` of the IDs used so far: actions, then conditions, sorted."""
        model = ET.Element("TreeNodesModel")
        for kind in ("Action", "Condition"):
            used = self.used[kind]
            for node_id in sorted(used):
                entry = ET.SubElement(model, kind, {"ID": node_id})
                if self.ports:
                    for position in range(1, used[node_id] + 1):
                        ET.SubElement(entry, "input_port", {"name": f"arg{position}", "type": "std::string"})
        return model


def _named(kind: str, position: int, root: str = "") -> dict[str, str]:
    """The ``name`` of a group or control node: its kind and its position among its siblings
    (``Sequence 3``), which makes every node's path of names unique (py_trees' XML reader requires
    it); at the root (position 0), ``root`` or none."""
    name = f"{kind} {position}" if position else root
    return {"name": name} if name else {}


def _comment_text(text: str) -> str:
    """Text that is safe inside an XML comment (no ``--``, no trailing ``-``), and reads back
    (:func:`_uncomment_text`): ``%`` is written ``%25`` and a ``-`` after a ``-`` or at the end ``%2D``
    (PDDL names may hold ``--``)."""
    text = text.replace("%", "%25")
    while "--" in text:
        text = text.replace("--", "-%2D")
    return text[:-1] + "%2D" if text.endswith("-") else text


def _uncomment_text(text: str) -> str:
    """The text :func:`_comment_text` wrote."""
    return text.replace("%2D", "-").replace("%25", "%")


# ---------------------------------------------------------------------------------------------- reader


def tree_from_btcpp(xml_text: str, task: GroundTask, source: str = "<xml>") -> Node:
    """Read a BehaviorTree.CPP v4 XML tree back into hbtp's model, resolving names against ``task``.

    Accepts what :func:`tree_to_btcpp` writes (every option), compact and explicit leaves, plain and
    reactive Sequence/Fallback, and ``<SubTree ID=...>`` references (each ``<BehaviorTree>`` is read
    once and shared by all its references). Raises :class:`InputError` for invalid XML, a BT.CPP v3
    document, unknown node IDs, literals or actions, nodes hbtp's model cannot express (decorators,
    parallel nodes, scripted pre/post conditions), a tree nested more than
    :data:`~hbtp.bt.nodes.MAX_TREE_DEPTH` levels deep, and one of more than
    :data:`~hbtp.bt.nodes.MAX_TREE_NODES` nodes once its SubTrees are expanded.
    """
    try:
        root = ET.fromstring(xml_text)
    except ET.ParseError as error:
        raise InputError(f"{source}: not valid XML ({error})") from None
    if root.tag != "root":
        raise InputError(f"{source}: not a BehaviorTree.CPP document (the top element is <{root.tag}>, not <root>)")
    version = root.get("BTCPP_format")
    if version is None or version.strip() == "3":
        found = "no BTCPP_format attribute" if version is None else 'BTCPP_format="3"'
        raise InputError(
            f"{source}: a BehaviorTree.CPP v3 document ({found}); hbtp reads format 4: convert it "
            '(Groot2 or BT.CPP\'s convert_v3_to_v4.py) and set <root BTCPP_format="4">'
        )
    if version.strip() != BTCPP_FORMAT:
        raise InputError(f'{source}: unsupported BTCPP_format="{version}" (hbtp reads format 4)')
    trees: dict[str, ET.Element] = {}
    for element in root.findall("BehaviorTree"):
        tree_id = element.get("ID", "")
        if tree_id in trees:
            raise InputError(f"{source}: two <BehaviorTree> elements with ID {tree_id!r}")
        trees[tree_id] = element
    if not trees:
        raise InputError(f"{source}: no <BehaviorTree> element")
    main = root.get("main_tree_to_execute")
    if main is None:
        if len(trees) > 1:
            raise InputError(f"{source}: several trees ({', '.join(sorted(trees))}) and no main_tree_to_execute")
        main = next(iter(trees))
    if main not in trees:
        raise InputError(f"{source}: main_tree_to_execute={main!r} names no <BehaviorTree>")
    reader = _Reader(task, trees)
    try:
        return reader.tree(main, main, 1).node
    except InputError as error:
        raise InputError(f"{source}: {error}") from None


_ABOUT = re.compile(
    r"<!--\s*generated by hbtp(?: for scenario (?P<scenario>.*?))?(?:, goal (?P<goal>.*?))?\s*-->", re.S
)


def btcpp_metadata(xml_text: str) -> dict[str, str]:
    """The scenario and goal that :func:`tree_to_btcpp` wrote into the document's leading comment
    (``{"scenario": ..., "goal": ...}``, each only when present)."""
    match = _ABOUT.search(xml_text, 0, 4096)
    if match is None:
        return {}
    found = match.groupdict().items()
    return {key: _uncomment_text(value.strip()) for key, value in found if value and value.strip()}


@dataclass(frozen=True, slots=True)
class _Read:
    """A node read from XML, with its size once expanded: nodes and depth (a leaf has depth 1)."""

    node: Node
    nodes: int
    depth: int


class _Reader:
    """Turns BT.CPP elements into nodes; ``where`` strings locate errors (``MainTree/ReactiveFallback[2]``)."""

    def __init__(self, task: GroundTask, trees: dict[str, ET.Element]) -> None:
        self.task = task
        self.trees = trees
        ids = node_ids(task)
        self.conditions = ids.condition_predicates
        self.actions = ids.action_predicates
        self.open_trees: list[str] = []
        self.done: dict[str, _Read] = {}

    def tree(self, tree_id: str, where: str, depth: int) -> _Read:
        """The tree of ``<BehaviorTree ID=tree_id>``, read once and then shared."""
        if tree_id in self.open_trees:
            raise InputError(f"{where}: SubTree {tree_id!r} includes itself")
        done = self.done.get(tree_id)
        if done is None:
            children = list(self.trees[tree_id])
            if len(children) != 1:
                raise InputError(f"{where}: a <BehaviorTree> needs exactly one child, found {len(children)}")
            self.open_trees.append(tree_id)
            try:
                done = self.node(children[0], f"{where}/{_tag(children[0])}", depth)
            finally:
                self.open_trees.pop()
            self.done[tree_id] = done
        if depth - 1 + done.depth > MAX_TREE_DEPTH:
            raise InputError(_too_deep())
        return done

    def node(self, element: ET.Element, where: str, depth: int) -> _Read:
        if depth > MAX_TREE_DEPTH + 1:  # + 1: the leaves of a Condition group
            raise InputError(_too_deep())
        tag = element.tag
        if tag in ("Condition", "Action", "Control", "SubTree"):
            node_id = element.get("ID")
            if not node_id:
                raise InputError(f"{where}: <{tag}> without an ID")
            if tag == "Control":
                if node_id not in _SEQUENCES and node_id not in _FALLBACKS:
                    raise InputError(f"{where}: unsupported control node {node_id!r}")
                tag = node_id
            elif tag == "SubTree":
                return self.subtree(element, node_id, where, depth)
            else:
                return _Read(self.leaf(element, tag, node_id, where), 1, 1)
        if tag in _SEQUENCES or tag in _FALLBACKS:
            self.check_attributes(element, where, ())
            children = list(element)
            if not children:
                raise InputError(f"{where}: a {tag} needs at least one child")
            reads = [self.node(child, f"{where}/{_tag(child)}[{i}]", depth + 1) for i, child in enumerate(children)]
            nodes = tuple(read.node for read in reads)
            if (
                tag in _SEQUENCES
                and _GROUP_NAME.fullmatch(element.get("name") or "") is not None
                and all(isinstance(n, Condition) for n in nodes)
            ):
                return _Read(
                    Condition(frozenset().union(*(n.literals for n in nodes if isinstance(n, Condition)))), 1, 1
                )
            total = 1 + sum(read.nodes for read in reads)
            if total > MAX_TREE_NODES:
                raise InputError(
                    f"{where}: the tree has more than {MAX_TREE_NODES:,} nodes once its SubTrees are expanded "
                    "(the most hbtp reads)"
                )
            height = 1 + max(read.depth for read in reads)
            if depth - 1 + height > MAX_TREE_DEPTH:
                raise InputError(_too_deep())
            return _Read(Fallback(nodes) if tag in _FALLBACKS else Sequence(nodes), total, height)
        if tag == "Inverter":
            return _Read(self.inverted(element, where, depth), 2, 2)
        if tag == "AlwaysSuccess":
            self.check_attributes(element, where, ())
            if len(element):
                raise InputError(f"{where}: AlwaysSuccess has no children")
            return _Read(Condition(frozenset()), 1, 1)
        if tag in _UNSUPPORTED_CONTROLS:
            raise InputError(f"{where}: {tag} is not supported ({_UNSUPPORTED_CONTROLS[tag]})")
        if tag in self.conditions:
            return _Read(self.leaf(element, "Condition", tag, where), 1, 1)
        if tag in self.actions:
            return _Read(self.leaf(element, "Action", tag, where), 1, 1)
        if tag in BUILTIN_IDS:
            raise InputError(f"{where}: the BT.CPP node {tag} has no counterpart in hbtp's trees")
        raise InputError(f"{where}: unknown node ID {tag!r} (not a predicate or action of task {self.task.name!r})")

    def inverted(self, element: ET.Element, where: str, depth: int) -> Condition:
        """An ``Inverter`` over one condition leaf: the negated literal ``~P(a)`` (see
        :mod:`hbtp.logic.negation`); the task must have its twin (a goal or precondition negates it)."""
        self.check_attributes(element, where, ())
        children = list(element)
        inner = (
            self.node(children[0], f"{where}/{_tag(children[0])}[0]", depth + 1).node if len(children) == 1 else None
        )
        if not isinstance(inner, Condition) or len(inner.literals) != 1:
            raise InputError(f"{where}: hbtp reads an Inverter only over one condition leaf (a negated literal)")
        (atom_id,) = inner.literals
        twin = self.task.negation_ids.get(atom_id)
        if twin is None:
            raise InputError(
                f"{where}: the tree negates {self.task.atoms[atom_id]}, which no goal or precondition of the task "
                "negates (give the goal that does)"
            )
        return Condition(frozenset({twin}))

    def subtree(self, element: ET.Element, tree_id: str, where: str, depth: int) -> _Read:
        if tree_id not in self.trees:
            raise InputError(f"{where}: SubTree {tree_id!r} names no <BehaviorTree>")
        extra = sorted(set(element.attrib) - _INFORMATIVE)
        if extra:
            raise InputError(f"{where}: SubTree port remapping ({', '.join(extra)}) is not supported")
        return self.tree(tree_id, f"{where}({tree_id})", depth)

    def leaf(self, element: ET.Element, kind: str, node_id: str, where: str) -> Node:
        table = self.conditions if kind == "Condition" else self.actions
        predicate = table.get(node_id)
        if predicate is None:
            other = self.actions if kind == "Condition" else self.conditions
            hint = (
                (" (it is an action ID)" if kind == "Condition" else " (it is a condition ID)")
                if node_id in other
                else ""
            )
            noun = "condition" if kind == "Condition" else "action"
            raise InputError(f"{where}: unknown {noun} ID {node_id!r}{hint}")
        if len(element):
            raise InputError(f"{where}: a {kind} leaf has no children")
        atom = self.grounded(element, node_id, predicate, where)
        if kind == "Condition":
            try:
                return Condition(frozenset({self.task.atom_id(atom)}))
            except InputError as error:
                raise InputError(f"{where}: {error}") from None
        try:
            return Action(self.task.action(atom).index)
        except InputError as error:
            raise InputError(f"{where}: {error}") from None

    def grounded(self, element: ET.Element, node_id: str, predicate: str, where: str) -> Atom:
        """The leaf's literal or action: from the ports ``arg1..argN``, else from its grounded ``name``."""
        ports: dict[int, str] = {}
        for key, value in element.attrib.items():
            match = _ARG_PORT.fullmatch(key)
            if match:
                ports[int(match.group(1))] = value.strip()
        self.check_attributes(element, where, [f"arg{i}" for i in ports])
        if ports:
            if sorted(ports) != list(range(1, len(ports) + 1)):
                raise InputError(f"{where}: {node_id} ports must be arg1..arg{len(ports)} without gaps")
            if any(value.startswith("{") for value in ports.values()):
                raise InputError(f"{where}: {node_id} reads a blackboard entry; hbtp needs the objects themselves")
            return Atom(predicate, tuple(ports[i] for i in range(1, len(ports) + 1)))
        name = element.get("name")
        if name:
            try:
                atom = parse_atom(name)
            except InputError:
                atom = None
            if atom is not None and atom.predicate == predicate:
                return atom
        return Atom(predicate, ())

    @staticmethod
    def check_attributes(element: ET.Element, where: str, ports: Iterable[str]) -> None:
        extra = sorted(set(element.attrib) - _INFORMATIVE - set(ports))
        if extra:
            raise InputError(
                f"{where}: unsupported attribute {extra[0]!r} (hbtp reads the ports arg1..argN, name and ID;"
                " scripted pre/post conditions change what a node does)"
            )


def _too_deep() -> str:
    return f"the tree is nested more than {MAX_TREE_DEPTH} levels deep (the most hbtp reads)"


def _tag(element: ET.Element) -> str:
    node_id = element.get("ID")
    return f"{element.tag}:{node_id}" if node_id else element.tag


def used_node_ids(tree: Node, task: GroundTask) -> tuple[list[str], list[str]]:
    """The sorted condition IDs and action IDs a tree uses (what its ``<TreeNodesModel>`` lists)."""
    ids = node_ids(task)
    conditions: set[str] = set()
    actions: set[str] = set()
    for node in walk(tree):
        if isinstance(node, Condition):
            conditions.update(ids.conditions[task.atoms[i].predicate] for i in node.literals)
        elif isinstance(node, Action):
            actions.add(ids.actions[task.actions[node.action].predicate])
    return sorted(conditions), sorted(actions)
