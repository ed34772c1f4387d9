"""voiopt: certified path planning and upload scheduling for value-of-information collection.

    import voiopt
    inst = voiopt.load("instances/case-study.json")
    metrics = voiopt.evaluate(inst, plan)

The names below are imported when first used (PEP 562), so that ``import voiopt`` costs next
to nothing: the ``voiopt`` command can then catch a Ctrl-C from its first moments, while numpy
and the rest are still importing (voiopt.__main__).
"""

from __future__ import annotations

import importlib
import importlib.util

from voiopt.errors import VoioptError

__version__ = "0.1.0"

# name -> the module it lives in
_HOMES = {
    **dict.fromkeys(("InstanceError", "OptionError", "PlanError", "VoioptError"), "voiopt.errors"),
    **dict.fromkeys(("case_study", "generate", "generate_set"), "voiopt.networks.generate"),
    **dict.fromkeys(("Channel", "Instance", "Links", "Robot", "Sensor", "load", "save"), "voiopt.core.instance"),
    "OBJECTIVES": "voiopt.objectives",
    "Policy": "voiopt.core.policy",
    "policy_from_function": "voiopt.core.function_policy",
    "evaluate_function": "voiopt.solvers.policy.function",
    "expected_metrics": "voiopt.core.expectation",
    **dict.fromkeys(("FleetPlan", "Plan", "load_plan"), "voiopt.core.plan"),
    **dict.fromkeys(("Result", "load_result"), "voiopt.core.result"),
    **dict.fromkeys(("Trajectory", "evaluate", "simulate"), "voiopt.core.simulate"),
    **dict.fromkeys(("METHODS", "solve"), "voiopt.solvers"),
    "Status": "voiopt.runtime.status",
}


def __getattr__(name: str):
    home = _HOMES.get(name)
    if home is None:  # a module of the package (voiopt.core.physics), as an eager import made it
        missing = AttributeError(f"module 'voiopt' has no attribute {name!r}")
        if not name.isidentifier() or name.startswith("__"):
            raise missing
        try:
            if importlib.util.find_spec(f"{__name__}.{name}") is None:
                raise missing
            return importlib.import_module(f"{__name__}.{name}")
        except (ImportError, VoioptError) as e:  # a module of an extra not installed: hasattr says False
            raise missing from e
    value = getattr(importlib.import_module(home), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_HOMES))


__all__ = [
    "Channel", "FleetPlan", "Instance", "InstanceError", "Links", "METHODS", "OBJECTIVES", "OptionError", "Plan",
    "PlanError", "Policy", "Result", "Robot", "Sensor", "Status", "Trajectory", "VoioptError", "case_study", "evaluate",
    "evaluate_function", "expected_metrics",
    "generate", "generate_set", "load", "load_plan", "load_result", "policy_from_function", "save", "simulate", "solve",
]
