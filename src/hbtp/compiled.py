"""hbtp's optional C extensions: LM-cut's rounds, the subset index's set-trie, the cheap estimates
(h² and the landmark sum) of the conditions a search generates, and the state equation's simplex.

Each is built when a C compiler and Python's headers are found at install (setuptools' optional
extensions, see pyproject.toml); without them hbtp runs the same algorithms in Python, with the same
results, several times slower. :func:`extension` imports one if it is built; :func:`kernel` picks
the one an object asked for, refusing an extension that is not built, and logs once per process,
at first use, what a missing one costs.
"""

from __future__ import annotations

import importlib
import logging
from types import ModuleType

from hbtp.errors import PlanningError

log = logging.getLogger(__name__)
#: The extensions already warned about (at most the four above: one warning each per process).
_warned: set[str] = set()

#: The optional extensions (module names under ``hbtp``).
LMCUT = "planning._lmcut"
SUBSETS = "logic._subsets"
CHEAP = "planning._cheap"
SIMPLEX = "planning._simplex"

#: How many conditions an estimate with C tables answers in Python before it makes them (a short
#: search never pays for them).
WARM_UP = 64


def extension(name: str) -> ModuleType | None:
    """The extension ``hbtp.<name>`` if it is built, else None."""
    try:
        return importlib.import_module(f"hbtp.{name}")
    except ImportError:
        return None


def kernel(
    module: ModuleType | None, name: str, *, compiled: bool, slower: str, instead: str = "runs in Python"
) -> ModuleType | None:
    """``module`` (the extension ``hbtp.<name>``) if ``compiled`` is asked for, else None.

    Raises :class:`PlanningError` when C is asked for and the extension is not built; ``slower``
    names what is slower when it is missing, and ``instead`` how it runs then, for the warning.
    """
    if module is None:
        if compiled:
            raise PlanningError(f"the C extension hbtp.{name} is not built here ({slower} {instead})")
        if name not in _warned:
            _warned.add(name)
            log.warning(
                "%s %s, several times slower: its C extension hbtp.%s was not built "
                "(install a C compiler, then reinstall hbtp)",
                slower,
                instead,
                name,
            )
    return module if compiled else None


def built() -> dict[str, bool]:
    """Whether each optional extension is built here, by name."""
    return {name: extension(name) is not None for name in (LMCUT, SUBSETS, CHEAP, SIMPLEX)}
