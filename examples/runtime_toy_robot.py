"""A toy robot driven by hbtp.runtime: the planned tree is ticked against Python callbacks, and the
runtime re-plans when an action keeps failing (here the right gripper is broken).

Run: python examples/runtime_toy_robot.py
"""

import logging

from hbtp.domains import load_scenario
from hbtp.runtime import ReplanOptions, Runtime

logging.basicConfig(level=logging.INFO, format="%(message)s")
scenario = load_scenario("robothow-small")
task = scenario.task

# A toy robot: its world is a set of literals; each action changes it as the model says, except
# that the right gripper is broken.
world = set(task.names(task.initial_state))


def act(name: str) -> str:
    action = task.actions[task.action(name).index]
    if name.startswith("RightGrab"):
        return "failure"  # the right gripper slips every time
    if not set(task.names(action.pre)) <= world:
        return "failure"
    world.difference_update(task.names(action.delete))
    world.update(task.names(action.add))
    return "success"


actions = {a.name: (lambda n=a.name: act(n)) for a in task.actions}
runtime = Runtime(
    scenario,
    "IsIn_apple_fridge & IsClose_fridge",
    actions,
    lambda: sorted(world),
    options=ReplanOptions(max_replans=5, budget_s=10),
    max_failures=2,
)
report = runtime.run(max_ticks=100)
print(report.status.value, "after", report.ticks, "ticks:", " -> ".join(report.called))
for replan in report.replans:
    print(f"re-planned at tick {replan.tick} ({replan.reason}) in {replan.seconds * 1000:.1f} ms: {replan.status}")
