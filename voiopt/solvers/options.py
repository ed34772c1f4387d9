"""Each method's options as a typed, frozen dataclass, checked once at the API edge.

Every method's options subclass ``Options`` (what all methods take: progress, the time limit
in seconds, the memory limit in GB) in the method's own module, with the same names and
defaults as the keyword options of its solve function (tests/solvers/test_registry.py holds
the two together). ``solvers.solve`` builds the options from the keywords it is given, so a
misspelt option is refused in one line, naming what the method takes.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from numbers import Integral
from typing import Any

from voiopt.errors import OptionError
from voiopt.solvers.base import DEFAULT_MEMORY_GB, check_limits

SCENARIO_COUNTS = {"samples": "the scenarios of a Monte Carlo value: a CI needs two",
                   "ir_samples": "the information relaxation's scenarios, or 0 for none"}


class UnknownOption(OptionError):
    """A keyword a method does not take; it lists the keywords it does (the command line
    rephrases it with its own flags)."""

    def __init__(self, key: str, method: str, takes: list[str]) -> None:
        super().__init__(f"{key}: not an option of method {method!r} (it takes {', '.join(takes)})")
        self.key, self.method, self.takes = key, method, takes


@dataclass(frozen=True)
class Options:
    progress: bool = False
    time_limit: float | None = None  # seconds
    memory_limit: float = DEFAULT_MEMORY_GB  # GB

    def __post_init__(self) -> None:
        check_limits(self.time_limit, self.memory_limit)
        for name, what in SCENARIO_COUNTS.items():  # a method's Monte Carlo counts, before any work
            v = getattr(self, name, 2)
            if isinstance(v, bool) or not isinstance(v, Integral) or not (v >= 2 or (v == 0 and name == "ir_samples")):
                raise OptionError(f"{name}: must be an integer >= 2 ({what}), got {v!r}")

    @classmethod
    def names(cls) -> list[str]:
        return [f.name for f in fields(cls)]

    @classmethod
    def of(cls, method: str, given: Mapping[str, Any]) -> Options:
        """The options of ``method`` from keywords; an unknown one is an UnknownOption that lists
        the keywords the method takes."""
        names = cls.names()
        for key in given:
            if key not in names:
                raise UnknownOption(key, method, [n for n in names if n != "progress"])
        return cls(**given)

    @classmethod
    def taken(cls, given: Mapping[str, Any]) -> dict[str, Any]:
        """Of some keywords, those this method takes (a sweep gives every method the same ones)."""
        names = set(cls.names())
        return {k: v for k, v in given.items() if k in names}

    def keywords(self) -> dict[str, Any]:
        """The options as the solve function's keywords."""
        return {f.name: getattr(self, f.name) for f in fields(self)}
