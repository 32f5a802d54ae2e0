"""The one exception hierarchy of hbtp.

Every error a user can cause (bad input, unknown names, unreadable files) derives from
:class:`InputError`; the command line turns it into a one-line message and exit code 2.
"""

from __future__ import annotations


class HbtpError(Exception):
    """Base class of every error raised by hbtp."""


class InputError(HbtpError):
    """Input that hbtp cannot accept: a malformed file, an unknown name, a bad option."""


class SourceError(InputError):
    """An error at a known place in a text source (a PDDL file, a dataset file)."""

    def __init__(self, message: str, source: str = "<string>", line: int = 0, column: int = 0) -> None:
        self.message = message
        self.source = source
        self.line = line
        self.column = column
        where = source
        if line:
            where += f":{line}"
            if column:
                where += f":{column}"
        super().__init__(f"{where}: {message}")


class PddlError(SourceError):
    """Malformed PDDL, or PDDL outside the supported subset."""


class DatasetError(SourceError):
    """A dataset file that cannot be read."""


class UnknownSymbolError(InputError):
    """A predicate, object, action or literal that the domain does not have."""


class GroundingError(HbtpError):
    """A lifted domain that cannot be compiled into a STRIPS task (for example a fluent disjunction)."""


class PlanningError(HbtpError):
    """A planning run that cannot start (for example inconsistent options)."""


class BackendError(HbtpError):
    """An LLM backend that failed: server down, rejected key, missing model file."""


class BackendTimeLimit(BackendError):
    """An LLM call not made, or stopped, because the time it was given was too short."""
