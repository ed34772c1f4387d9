"""The solver registry: method name -> ``solve(instance, objective, **options) -> Result``.

Modules are imported only when their method is used, so optional extras and numba
compilation cost nothing until needed.
"""

from __future__ import annotations

import importlib
from typing import Any

from voiopt.errors import OptionError
from voiopt.instance import Instance
from voiopt.result import Result
from voiopt.simulate import check_objective

# method name -> (module, function)
METHODS: dict[str, tuple[str, str]] = {}


def register(name: str, module: str, function: str = "solve") -> None:
    METHODS[name] = (module, function)


def solve(instance: Instance, method: str = "milp", objective: str = "mean-min-voi", **options: Any) -> Result:
    """Solve ``instance`` with ``method`` for ``objective``; every value in the Result is simulated."""
    check_objective(objective)
    if method not in METHODS:
        raise OptionError(f"method: unknown method {method!r} (choose from {', '.join(METHODS) or 'none'})")
    module, function = METHODS[method]
    fn = getattr(importlib.import_module(module), function)
    return fn(instance, objective, **options)
