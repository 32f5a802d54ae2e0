"""Prompts in the paper's shape (Fig. 7), built from the scenario itself, and few-shot retrieval.

Two shapes of the same content:

* chat: a system message with the scenario (condition predicates, action predicates with costs,
  object categories and members), the rules and few-shot demonstrations; the user asks for a goal.
  Reflective feedback continues the conversation.
* completion (for base models such as the local Gemma-3 270M): demonstrations only, in the datasets'
  format, ending with ``Goals: <goal>`` and ``Optimal Actions:`` for the model to continue.

Demonstrations are retrieved from the scenario's example pool by lexical similarity to *all* the
goal's literals: the Jaccard similarity of the literal sets counts most, then that of the objects,
then that of the predicates, so a short demonstration of the same kind beats a long one that merely
mentions the same object. In the completion prompt the most similar demonstration comes last, next
to the question.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from hbtp.datasets.records import Record
from hbtp.errors import InputError
from hbtp.llm.backend import Message, PromptStyle, Request
from hbtp.llm.constrain import Bounds, Constraint, constraint_of
from hbtp.llm.spelling import Spelling
from hbtp.llm.vocabulary import as_names, vocabulary_of
from hbtp.logic.atoms import Atom, parse_conjunction
from hbtp.logic.names import ActionNames
from hbtp.logic.task import GroundTask

RULES = """[System]
[Condition Predicates] lists the predicates of conditions and the categories of their arguments.
[Action Predicates] lists the actions with their costs in parentheses. [Objects] lists the categories.
[Few-shot Demonstrations] map goals to Optimal Actions, Vital Action Predicates and Vital Objects.
1) Analyse the goal (literals of [Condition Predicates] joined by &) and find the cheapest actions that achieve it.
2) Begin with 'Optimal Actions:' followed by a comma-separated list of actions, an underscore between the verb and \
each object ({examples}), in execution order, minimising the total cost.
3) Then 'Vital Action Predicates:' followed by the comma-separated verbs used.
4) Then 'Vital Objects:' followed by the comma-separated objects used.
5) Use only actions, predicates and objects from the lists above.
6) Follow the demonstrations' format exactly: three lines, no explanations."""


class Retrieval(enum.StrEnum):
    """How the demonstrations of a prompt are chosen (``--retrieval``)."""

    LEXICAL = "lexical"  #: shared literals, objects and predicates (:func:`retrieve_examples`)
    EMBEDDINGS = "embeddings"  #: sentence embeddings (the optional extra, :mod:`hbtp.llm.embeddings`)

    @classmethod
    def named(cls, text: str) -> Retrieval:
        """``text`` as a retrieval (:class:`~hbtp.errors.InputError` for another)."""
        try:
            return cls(text)
        except ValueError:
            raise InputError(f"unknown retrieval {text!r}; choose one of: {', '.join(RETRIEVALS)}") from None


RETRIEVALS: tuple[str, ...] = tuple(r.value for r in Retrieval)

#: Three short lines; a base model that starts repeating itself is cut off here.
COMPLETION_MAX_TOKENS = 160
#: A constrained reply ends with its grammar (bounded lists); this only guards against a runaway.
CONSTRAINED_MAX_TOKENS = 256

#: Demonstrations added per feedback round (a base model cannot follow the feedback's instructions).
FEEDBACK_EXTRA_EXAMPLES = 2


@dataclass(frozen=True)
class PromptOptions:
    examples: int = 5
    #: ``None``: the backend's own (:attr:`hbtp.llm.backend.Backend.prompt_style`; chat without a
    #: backend). ``"chat"`` / ``"completion"`` are accepted and stored as their :class:`PromptStyle`.
    style: PromptStyle | str | None = None
    include_objects: bool = True  # list category members in the chat prompt
    max_tokens: int = 256  # chat; completion replies get COMPLETION_MAX_TOKENS
    exclude_same_goal: bool = False  # benchmarks: never show a demonstration of the very goal asked
    retrieval: Retrieval = Retrieval.LEXICAL
    #: Constrained decoding (:mod:`hbtp.llm.constrain`): requests carry the reply's grammar and
    #: schema, with lists bounded by the demonstrations shown; backends that can, enforce it.
    constrain: bool = True
    #: The backend is a model taught the domain (a local adapter, :mod:`hbtp.train`): its
    #: completion prompt is the question alone (:func:`taught_prompt`), no vocabulary, no demonstrations.
    taught: bool = False
    #: How a taught model spells the actions of its plan (its adapter's, :mod:`hbtp.llm.spelling`).
    spelling: Spelling = Spelling.UNDERSCORED

    def __post_init__(self) -> None:
        object.__setattr__(self, "retrieval", Retrieval.named(self.retrieval))
        if isinstance(self.style, str):
            try:
                object.__setattr__(self, "style", PromptStyle(self.style))
            except ValueError:
                choices = ", ".join(s.value for s in PromptStyle)
                raise InputError(f"unknown prompt style {self.style!r}; choose one of: {choices}") from None

    def for_backend(
        self, style: PromptStyle, taught: bool = False, spelling: Spelling = Spelling.UNDERSCORED
    ) -> PromptOptions:
        """These options with ``style`` where none was chosen, for a backend ``taught`` the domain or
        not (with the ``spelling`` of the actions it was taught)."""
        chosen = self if self.style is not None else replace(self, style=style)
        return replace(chosen, taught=taught, spelling=spelling)


@dataclass(frozen=True)
class Feedback:
    """What a failed round tells the model (§III-C d): the top-k longest partial paths (action
    names in execution order) and the action predicates and objects the space left out."""

    longest_paths: tuple[tuple[str, ...], ...] = ()
    missing_predicates: tuple[str, ...] = ()
    missing_objects: tuple[str, ...] = ()


def _goal_features(goal: str) -> tuple[frozenset[str], frozenset[str], frozenset[str]]:
    try:
        atoms = parse_conjunction(goal)
    except Exception:  # a record with a broken goal simply matches nothing
        return frozenset(), frozenset(), frozenset()
    literals = frozenset(str(a) for a in atoms)
    objects = frozenset(arg for a in atoms for arg in a.args)
    predicates = frozenset(a.predicate for a in atoms)
    return literals, objects, predicates


def _jaccard(left: frozenset[str], right: frozenset[str]) -> float:
    union = len(left | right)
    return len(left & right) / union if union else 0.0


def retrieve_examples(
    goal: str,
    pool: Sequence[Record],
    k: int,
    exclude_goal: bool = False,
    retrieval: Retrieval = Retrieval.LEXICAL,
) -> list[Record]:
    """The ``k`` records of ``pool`` most similar to ``goal`` (ties: shorter goals, then file order).

    ``retrieval`` is ``lexical`` (the default, below) or ``embeddings`` (the optional extra, see
    :mod:`hbtp.llm.embeddings`).
    """
    if k <= 0 or not pool:
        return []
    retrieval = Retrieval.named(retrieval)  # (text from an untyped caller is checked here)
    literals, objects, predicates = _goal_features(goal)
    dense: list[float] | None = None
    if retrieval is Retrieval.EMBEDDINGS:
        from hbtp.llm.embeddings import similarities

        dense = similarities(goal, [record.goal for record in pool])
    scored: list[tuple[float, int, int, Record]] = []
    for position, record in enumerate(pool):
        other_literals, other_objects, other_predicates = _goal_features(record.goal)
        if exclude_goal and other_literals == literals:
            continue
        if dense is not None:
            score = dense[position]
        else:
            score = (
                3.0 * _jaccard(literals, other_literals)
                + 2.0 * _jaccard(objects, other_objects)
                + 1.0 * _jaccard(predicates, other_predicates)
            )
        scored.append((-score, len(other_literals), position, record))
    scored.sort(key=lambda item: item[:3])
    return [record for *_, record in scored[:k]]


def format_example(record: Record) -> str:
    return f"Goals: {_normal_goal(record.goal)}\n{record.reply_block()}"


def _normal_goal(goal: str) -> str:
    return " & ".join(part.strip() for part in goal.split("&"))


def scenario_text(task: GroundTask | ActionNames, include_objects: bool = True) -> str:
    vocabulary = vocabulary_of(task)
    lines = ["[Condition Predicates]", ", ".join(vocabulary.condition_predicates), "", "[Action Predicates]"]
    lines.append(", ".join(vocabulary.action_predicates))
    if include_objects:
        lines += ["", "[Objects]"]
        lines += [f"<{name}> = [{', '.join(members)}]" for name, members in vocabulary.categories]
    return "\n".join(lines)


def taught_prompt(goal: str) -> str:
    """The completion prompt a taught model is asked, and trained on: the goal and the reply's start."""
    return f"Goals: {_normal_goal(goal)}\nOptimal Actions:"


def taught_reply(plan: Iterable[Atom], spelling: Spelling = Spelling.UNDERSCORED) -> str:
    """What a taught model learns to answer :func:`taught_prompt` with: an optimal ``plan``, in
    ``spelling``, then the blank line that ends a reply (a stop string).

    The plan alone: the vital predicates and objects of an optimal label are the plan's own
    (Q̂ = Q(p̂), Ô = O(p̂)), which the pruning adds to any reply anyway, so a taught model does not
    spend tokens on them."""
    return spelling.plan(plan) + "\n\n"


def build_request(
    task: GroundTask | ActionNames,
    goal: str,
    pool: Sequence[Record],
    options: PromptOptions = PromptOptions(),
    *,
    scenario: str = "",
    avoid: Iterable[str] = (),
) -> Request:
    """The first question for ``goal`` (round 0), in both shapes. A taught model is asked the question
    alone: its completion prompt has no demonstrations and its conversation no system message (the
    vocabulary, demonstrations and rules a base model reads), which in a large world would cost more
    to write than the model takes to answer."""
    shown = 0 if options.taught else options.examples
    examples = retrieve_examples(goal, pool, shown, options.exclude_same_goal, options.retrieval)
    closest_last = "\n\n".join(format_example(r) for r in reversed(examples))
    goal_text = _normal_goal(goal)
    avoid_text = _avoid_text(avoid)
    system = () if options.taught else (Message("system", _system_text(task, examples, options)),)
    completion = (closest_last + "\n\n" if closest_last else "") + (avoid_text + "\n" if avoid_text else "")
    completion += taught_prompt(goal_text)
    constraint = _constraint(task, examples, options)
    return Request(
        messages=(*system, Message("user", f"Goals: {goal_text}" + _suffix(avoid_text))),
        completion_prompt=completion,
        goal=goal_text,
        scenario=scenario,
        max_tokens=_max_tokens(options, constraint),
        stop=("\n\n", "Goals:"),
        constraint=constraint,
        taught=options.taught,
        spelling=options.spelling,
    )


def _system_text(task: GroundTask | ActionNames, examples: Sequence[Record], options: PromptOptions) -> str:
    """A base model's system message: the vocabulary, the demonstrations and the rules."""
    demos = "\n\n".join(format_example(r) for r in examples)
    rules = RULES.format(examples=", ".join(_format_examples(task)))
    parts = (scenario_text(task, options.include_objects), f"[Few-shot Demonstrations]\n{demos}", rules)
    return "\n\n".join(part for part in parts if part)


def _constraint(
    task: GroundTask | ActionNames, examples: Sequence[Record], options: PromptOptions
) -> Constraint | None:
    """The reply's constraint, its lists bounded by the longest of the ``examples`` shown."""
    if not options.constrain:
        return None
    lengths = [(len(r.optimal_actions), len(r.vital_predicates), len(r.vital_objects)) for r in examples]
    return constraint_of(task, Bounds.after(lengths), path_only=options.taught, spelling=options.spelling)


def _max_tokens(options: PromptOptions, constraint: Constraint | None) -> int:
    if options.style is not PromptStyle.COMPLETION:
        return options.max_tokens
    return min(options.max_tokens, CONSTRAINED_MAX_TOKENS if constraint else COMPLETION_MAX_TOKENS)


def _format_examples(task: GroundTask | ActionNames) -> list[str]:
    """Two action names of the scenario itself (the fewest and the most arguments) for the rules."""
    actions = as_names(task).actions
    if not actions:
        return []
    by_arity = sorted(range(len(actions)), key=lambda i: (len(actions[i].args), i))
    return list(dict.fromkeys((actions[by_arity[0]].underscored, actions[by_arity[-1]].underscored)))


def _avoid_text(avoid: Iterable[str]) -> str:
    items = sorted(set(avoid))
    return f"Do not use (not in this domain): {', '.join(items)}" if items else ""


def _suffix(text: str) -> str:
    return f"\n{text}" if text else ""


def retry_request(previous: Request, reply_text: str, problems: Sequence[str], blacklist: Iterable[str]) -> Request:
    """Ask again after the grammar checker found problems (the paper's blacklist)."""
    avoid = _avoid_text(blacklist)
    message = "Your answer has problems: " + "; ".join(problems) + "." + _suffix(avoid)
    message += "\nAnswer again in the required format, using only names from the lists."
    head, _, _ = previous.completion_prompt.rpartition("Goals:")
    completion = re.sub(r"Do not use \(not in this domain\):[^\n]*\n", "", head)
    completion += (avoid + "\n" if avoid else "") + f"Goals: {previous.goal}\nOptimal Actions:"
    return _replace(
        previous,
        messages=(*previous.messages, Message("assistant", reply_text), Message("user", message)),
        completion_prompt=completion,
        attempt=previous.attempt + 1,
    )


def feedback_request(
    previous: Request,
    reply_text: str,
    feedback: Feedback,
    pool: Sequence[Record],
    options: PromptOptions = PromptOptions(),
    blacklist: Iterable[str] = (),
) -> Request:
    """Reflective feedback (§III-C d): the next round's question after ``previous`` was answered
    with ``reply_text`` and the planner failed; a base model gets :data:`FEEDBACK_EXTRA_EXAMPLES`
    more demonstrations per round instead."""
    lines = ["The planner could not reach the initial state with the actions you allowed."]
    if feedback.longest_paths:
        lines.append("The longest partial plans it found (they end at the goal):")
        lines += [f"{i}. {', '.join(path) if path else '(none)'}" for i, path in enumerate(feedback.longest_paths, 1)]
    if feedback.missing_predicates:
        lines.append(f"Action predicates left out: {', '.join(feedback.missing_predicates)}")
    if feedback.missing_objects:
        lines.append(f"Objects left out: {', '.join(feedback.missing_objects)}")
    lines.append(
        "Find what is missing (an action, a predicate or an object) and answer again with "
        "Optimal Actions, Vital Action Predicates and Vital Objects."
    )
    round_ = previous.round + 1
    examples = options.examples + FEEDBACK_EXTRA_EXAMPLES * round_
    more = retrieve_examples(previous.goal, pool, examples, options.exclude_same_goal, options.retrieval)
    demos = "\n\n".join(format_example(r) for r in reversed(more))
    avoid = _avoid_text(blacklist)
    completion = (demos + "\n\n" if demos else "") + (avoid + "\n" if avoid else "")
    completion += f"Goals: {previous.goal}\nOptimal Actions:"
    return _replace(
        previous,
        messages=(*previous.messages, Message("assistant", reply_text), Message("user", "\n".join(lines))),
        completion_prompt=completion,
        round=round_,
        attempt=0,
        taught=False,  # demonstrations: a taught model's base answers feedback rounds
    )


def _replace(request: Request, **changes: Any) -> Request:
    return replace(request, **changes)


def estimate_tokens(text: str) -> int:
    """A tokenizer-free estimate: words, numbers and punctuation marks (about 1.3x words in practice)."""
    return len(re.findall(r"[A-Za-z]+|\d+|[^\sA-Za-z\d]", text))
