"""voiopt.solvers.milp.cvxpy_problem: the time-expanded MILP as a cvxpy Problem, solved by
cvxpy's HiGHS back-end, its plan valued by the simulator against VoI-Lib's certificates."""

from __future__ import annotations

import sys

import pytest

from voiopt.core.result import Result
from voiopt.errors import MissingExtraError, OptionError
from voiopt.solvers.milp import cvxpy_problem
from voiopt.voilib import library as voilib

INSTANCES = voilib.instances()
# five small VoI-Lib instances; min-voi optima from 8e-20 to 1e4 bit/s, and the other objectives
CASES = [("walls-n4-t30-002", "min-voi"), ("paper-n3-t10-000", "min-voi"), ("paper-n3-t10-001", "mean-min-voi"),
         ("case-study", "mean-min-voi"), ("case-study", "max-aoi"), ("paper-n5-t30-001", "min-voi")]


@pytest.mark.parametrize("name, objective", CASES)
def test_cvxpy_problem_with_highs_gives_the_certified_optimum(name, objective):
    cp = pytest.importorskip("cvxpy", reason="cvxpy is not installed (pip install 'voiopt[cvxpy]')")
    inst = INSTANCES[name]
    problem, to_plan = cvxpy_problem(inst, objective)
    assert isinstance(problem, cp.Problem)
    problem.solve(solver=cp.HIGHS)
    assert problem.status == cp.OPTIMAL
    result = Result.from_plan(inst, "cvxpy", objective, to_plan(), status="feasible", runtime_s=0.0)
    assert result.value == pytest.approx(voilib.certified(inst, objective), rel=1e-6)


def test_to_plan_before_a_solve_says_so():
    pytest.importorskip("cvxpy", reason="cvxpy is not installed (pip install 'voiopt[cvxpy]')")
    _, to_plan = cvxpy_problem(INSTANCES["paper-n3-t10-000"], "min-voi")
    with pytest.raises(OptionError, match="no solution to read"):
        to_plan()


def test_without_cvxpy_one_line_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "cvxpy", None)  # import cvxpy raises ImportError
    with pytest.raises(MissingExtraError) as e:
        cvxpy_problem(INSTANCES["paper-n3-t10-000"], "min-voi")
    assert "pip install 'voiopt[cvxpy]'" in str(e.value) and "\n" not in str(e.value)


def test_highs_and_scip_default_to_a_zero_gap_and_the_caller_still_decides(monkeypatch):
    cp = pytest.importorskip("cvxpy", reason="cvxpy is not installed (pip install 'voiopt[cvxpy]')")
    problem, _ = cvxpy_problem(INSTANCES["paper-n3-t10-000"], "min-voi")
    seen = []
    monkeypatch.setattr(cp.Problem, "solve", lambda self, *a, **kw: seen.append(kw))
    problem.solve(solver=cp.HIGHS)
    problem.solve(solver="highs", mip_rel_gap=0.01)
    problem.solve(solver=cp.SCIP)
    problem.solve(solver=cp.SCIP, scip_params={"limits/gap": 0.1})
    assert [kw.get("mip_rel_gap") for kw in seen[:2]] == [0.0, 0.01]
    assert [kw["scip_params"]["limits/gap"] for kw in seen[2:]] == [0.0, 0.1]
