"""The Pyomo model (the [pyomo] extra) is the same MILP: solved by HiGHS through Pyomo's
appsi interface it reaches the array model's optimum, which is the brute-force optimum."""

from __future__ import annotations

import pytest
from conftest import tiny_instances
from oracles.bruteforce import brute_force

import voiopt
from voiopt.core.plan import Plan
from voiopt.solvers.milp.solver import TOLERANCES, solve

pyo = pytest.importorskip("pyomo.environ")
from voiopt.solvers.milp import pyomo as pyomo_model  # noqa: E402


@pytest.fixture(scope="module")
def highs():
    solver = pyo.SolverFactory("appsi_highs")
    if not solver.available():
        pytest.skip("HiGHS is not reachable through pyomo's appsi interface")
    # exact, with the array solver's tight tolerances: at HiGHS's default feasibility
    # tolerance (1e-6) its presolve cuts off the true optimum of one of these instances
    solver.options.update({"mip_rel_gap": 0.0, **TOLERANCES})
    return solver


@pytest.mark.parametrize("objective", list(voiopt.OBJECTIVES))
def test_pyomo_model_has_the_array_models_optimum(highs, objective):
    for inst in tiny_instances(8, seed=321):
        m = pyomo_model.build(inst, objective)
        highs.solve(m)
        best, _ = brute_force(inst, objective)
        array = solve(inst, objective)
        assert array.status == "optimal"
        assert pyo.value(m.objective) == pytest.approx(best, rel=1e-6)
        assert array.value == pytest.approx(best, rel=1e-6)
        idx, sched = pyomo_model.plan_indices(m, inst, objective)
        simulated = voiopt.evaluate(inst, Plan.from_indices(inst, idx, sched))[objective]
        assert simulated == pytest.approx(best, rel=1e-6)


def test_pyomo_model_is_readable():
    m = pyomo_model.build(tiny_instances(1)[0], "mean-min-voi")
    names = {c.local_name for c in m.component_objects(pyo.Constraint)}
    assert names == {"one_point", "move", "tdma", "level", "worth"}
    assert m.objective.sense == pyo.maximize
