"""voiopt: certified path planning and upload scheduling for value-of-information collection.

    import voiopt
    inst = voiopt.load("instances/case-study.json")
    metrics = voiopt.evaluate(inst, plan)
"""

from voiopt.errors import InstanceError, OptionError, PlanError, VoioptError
from voiopt.generate import case_study, generate, generate_set
from voiopt.instance import Channel, Instance, Robot, Sensor, load, save
from voiopt.objectives import OBJECTIVES
from voiopt.plan import FleetPlan, Plan, load_plan
from voiopt.result import Result, load_result
from voiopt.simulate import Trajectory, simulate
from voiopt.solvers import METHODS, solve

__version__ = "0.1.0"


def evaluate(instance: Instance, plan) -> dict[str, float]:
    """The four metrics of a plan (a Plan or FleetPlan, or a dict holding a plan or a whole result)."""
    if not isinstance(plan, (Plan, FleetPlan)):
        plan = Plan.from_dict(plan)
    return simulate(instance, plan).metrics


__all__ = [
    "Channel", "FleetPlan", "Instance", "InstanceError", "METHODS", "OBJECTIVES", "OptionError", "Plan",
    "PlanError", "Result", "Robot", "Sensor", "Trajectory", "VoioptError", "case_study", "evaluate",
    "generate", "generate_set", "load", "load_plan", "load_result", "save", "simulate", "solve",
]
