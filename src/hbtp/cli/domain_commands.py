"""``hbtp scenarios``, ``hbtp ground`` and ``hbtp export-pddl``."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import click

from hbtp.cli.options import ScenarioSource, echo_json, scenario_options, time_limit_option
from hbtp.deadline import Deadline
from hbtp.domains import Scenario, load_scenario, scenario_names, write_domain, write_grounded, write_problem
from hbtp.domains.lifted import And, AtomFormula
from hbtp.errors import InputError
from hbtp.files import write_all_atomically
from hbtp.logic.relevance import relevant_actions


@click.command()
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def scenarios(as_json: bool) -> int:
    """List the shipped scenarios with their sizes: the actions plans use, and the self-placements
    left out of them (the paper's action lists hold both)."""
    rows = [load_scenario(name).summary() for name in scenario_names()]
    if as_json:
        echo_json(rows)
        return 0
    click.echo(f"{'name':16} {'actions':>8} {'left out':>8} {'action preds':>12} {'objects':>8} {'s0':>4}  title")
    for row in rows:
        click.echo(
            f"{row['name']:16} {row['actions']:>8} {row['left_out']:>8} {row['action_predicates']:>12} "
            f"{row['objects']:>8} {row['s0']:>4}  {row['title']}"
        )
    return 0


@click.command()
@scenario_options
@click.option("--names", is_flag=True, help="Print one grounded action name per line (Walk(apple)).")
@click.option("--json", "as_json", is_flag=True, help="Print every grounded action with pre/add/del/cost.")
@time_limit_option
def ground(source: ScenarioSource, names: bool, as_json: bool, time_limit: float) -> int:
    """Ground a scenario or your PDDL files and show the result (with the actions relevant to the
    problem's :goal when it has one: those a search of it uses)."""
    loaded = source.load(deadline=Deadline(time_limit))
    task = loaded.task
    if names:
        click.echo("\n".join(a.name for a in task.actions))
        return 0
    if as_json:
        echo_json(
            {
                **loaded.summary(),
                "goal_actions": _goal_actions(loaded),
                "actions_detail": [
                    {
                        "name": a.name,
                        "pre": task.names(a.pre),
                        "add": task.names(a.add),
                        "del": task.names(a.delete),
                        "cost": a.cost,
                    }
                    for a in task.actions
                ],
                "initial_state": task.names(task.initial_state),
            }
        )
        return 0
    summary = loaded.summary()
    for key in ("name", "actions", "action_predicates", "objects", "s0", "atoms", "mutex_groups"):
        click.echo(f"{key:18} {summary[key]}")
    if loaded.left_out:
        click.echo(f"{'left_out':18} {len(loaded.left_out)} (self-placements such as {loaded.left_out[0]})")
    click.echo(f"{'grounding_s':18} {loaded.load_seconds:.3f}")
    goal_actions = _goal_actions(loaded)
    if goal_actions is not None:
        click.echo(f"{'goal_actions':18} {goal_actions} (relevant to the problem's :goal)")
    return 0


def _goal_actions(loaded: Scenario) -> int | None:
    """How many ground actions are relevant to the problem's :goal (``None`` without one)."""
    try:
        text = loaded.problem_goal()
    except InputError:  # the shipped scenarios' problems hold no goal
        return None
    scenario, goal = loaded.resolve_goal(text)
    return len(relevant_actions(scenario.task, goal))  # the actions Scenario.for_goal keeps


@click.command("export-pddl")
@scenario_options
@click.option("-g", "--goal", required=True, help='Goal, e.g. "IsIn_milk_fridge & IsClose_fridge".')
@click.option(
    "-o",
    "--out",
    "out_dir",
    required=True,
    type=click.Path(file_okay=False),
    help="Output folder (created if missing).",
)
@click.option(
    "--lifted",
    is_flag=True,
    help="Write the lifted domain and problem (they read back unchanged) instead of the grounded encoding.",
)
def export_pddl(
    source: ScenarioSource,
    goal: str,
    out_dir: str,
    lifted: bool,
) -> int:
    """Write domain.pddl and problem.pddl for a goal.

    By default the grounded STRIPS encoding, for other planners such as Fast Downward: one
    parameterless action per ground action. Read back into hbtp it is not the same scenario (no
    objects; a literal no action changes becomes static unless --keep-fluent names it, as a comment
    in the file says). --lifted writes the domain and problem themselves (read -> write -> read is the
    identity); grounding them again needs the scenario's --objects, --keep-fluent and --mutex options.
    """
    loaded = source.load()
    resolved = loaded.task.resolve_goal(goal)
    out = Path(out_dir)
    if lifted:
        goal_formula = And(tuple(AtomFormula(a.predicate, a.args) for a in resolved.atoms))
        problem = dataclasses.replace(loaded.pddl.problem, goal=goal_formula, minimize_cost=True)
        domain_text, problem_text = write_domain(loaded.pddl.domain), write_problem(problem)
    else:
        domain_text, problem_text = write_grounded(loaded.task, resolved)
    write_all_atomically({out / "domain.pddl": domain_text, out / "problem.pddl": problem_text}, create_folders=True)
    click.echo(f"wrote {out / 'domain.pddl'} and {out / 'problem.pddl'}")
    return 0
