"""The status of a result (MODEL.md section 6): one enum whose values are the JSON strings.

The stop rule's reasons (``TIME_LIMIT``, ``MEMORY_LIMIT``, ``INTERRUPTED``) are statuses, which
is why this lives beside it in the runtime rather than with the Result.
"""

from __future__ import annotations

from enum import Enum


class Word(str, Enum):
    """An enum whose members are the words files and messages write: each equals and prints as
    its value (``Status.OPTIMAL == "optimal"``, f"{Worth.VOI}" is "voi")."""

    def __str__(self) -> str:
        return self.value

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)


class Status(Word):
    """A result's status. It equals its JSON string (``Status.OPTIMAL == "optimal"``) and prints
    as it, so files, messages and comparisons read the same as the words of MODEL.md."""

    OPTIMAL = "optimal"  # proven: the bound and the simulated value agree
    FEASIBLE = "feasible"  # a plan, no proof
    TIME_LIMIT = "time_limit"  # stopped at the time limit, with a plan
    MEMORY_LIMIT = "memory_limit"  # stopped at the memory limit, with a plan
    INTERRUPTED = "interrupted"  # stopped by Ctrl-C, SIGTERM or SIGHUP, with a plan
    INFEASIBLE = "infeasible"
    ERROR = "error"

    @property
    def stopped(self) -> bool:
        """Stopped early by a limit or a signal (with a plan)."""
        return self in STOPPED

    @property
    def has_plan(self) -> bool:
        """A status that a result reaches only with a plan (a stopped run may have none yet:
        a fleet's milp stopped before its first plan)."""
        return self in (Status.OPTIMAL, Status.FEASIBLE)


STOPPED = frozenset({Status.TIME_LIMIT, Status.MEMORY_LIMIT, Status.INTERRUPTED})
