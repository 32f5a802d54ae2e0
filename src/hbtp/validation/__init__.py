"""Check OBTEA's optimality against Fast Downward (the optional ``validate`` extra).

A record's goal is exported with :func:`~hbtp.domains.pddl_writer.write_grounded` (the exact task
the planners search, as STRIPS + action costs) and solved by Fast Downward's optimal configuration,
A* with LM-cut. Its plan is replayed in hbtp's task and its cost must equal OBTEA's D(T).

Two ways to run Fast Downward, both from the ``up-fast-downward`` package:

* ``unified-planning``: unified-planning's ``PDDLReader`` reads the files and
  ``OneshotPlanner(name="fast-downward-opt")`` solves them. The reader needs seconds for a few
  hundred grounded actions and minutes for RobotHow's 7329, so the parsed problem is kept with the
  task and only the goal is replaced for the next record.
* ``driver``: the Fast Downward driver shipped in ``up-fast-downward`` runs on the exported files
  directly (same build, same ``astar(lmcut())`` search): seconds even for RobotHow.

``auto`` takes unified-planning up to :data:`AUTO_DRIVER_ACTIONS` grounded actions, the driver above.

Fast Downward is GPL: it is only used here, imported lazily, and only when the ``validate`` extra is
installed (``pip install -e '.[validate]'``). Its driver writes into the working directory, so each
call runs in a fresh temporary directory made the working directory (so do not call it from
threads: the working directory belongs to the process).

Declared mutexes (RobotHow, RobotHow-Small) prune conditions that Fast Downward does not know
about, so every record is planned twice, with the scenario's mutexes and with ``mutexes=None``: the
second cost must match Fast Downward exactly, and a record whose optimum changes with the
mutexes is reported.
"""

from hbtp.validation.compare import (
    compare_files,
    compare_optimal,
    compare_record,
    decided,
    has_declared_mutexes,
    iter_comparisons,
    run_obtea,
)
from hbtp.validation.fast_downward import (
    AUTO_DRIVER_ACTIONS,
    COMPARE_TIME_LIMIT,
    ENGINE,
    ENGINES,
    INSTALL_HINT,
    Engine,
    FastDownwardRun,
    FilesRun,
    ObteaRun,
    RunStatus,
    choose_engine,
    fast_downward_cost,
    lifted_fast_downward_cost,
    run_fast_downward,
    run_fast_downward_files,
)

__all__ = [
    "AUTO_DRIVER_ACTIONS",
    "COMPARE_TIME_LIMIT",
    "ENGINE",
    "ENGINES",
    "INSTALL_HINT",
    "Engine",
    "FastDownwardRun",
    "FilesRun",
    "ObteaRun",
    "RunStatus",
    "choose_engine",
    "compare_files",
    "compare_optimal",
    "compare_record",
    "decided",
    "fast_downward_cost",
    "has_declared_mutexes",
    "iter_comparisons",
    "lifted_fast_downward_cost",
    "run_fast_downward",
    "run_fast_downward_files",
    "run_obtea",
]
