"""Results: simulated values, honest optimality claims, atomic and lossless files."""

from __future__ import annotations

import json
import os

import pytest

import voiopt
from voiopt import objectives
from voiopt.core.plan import Plan
from voiopt.core.result import Result, load_result
from voiopt.networks.generate import case_study_plan

CASE_STUDY_PLAN = case_study_plan().to_dict()


@pytest.fixture
def plan():
    return Plan.from_dict(CASE_STUDY_PLAN)


def test_value_comes_from_the_simulator(case_study, plan):
    r = Result.from_plan(case_study, "test", "min-voi", plan, status="feasible")
    assert r.value == voiopt.evaluate(case_study, plan)["min-voi"]
    assert r.metrics == voiopt.evaluate(case_study, plan)
    assert r.bound is None and r.gap is None


def test_optimal_needs_bound_agreement(case_study, plan):
    v = voiopt.evaluate(case_study, plan)["mean-min-voi"]
    r = Result.from_plan(case_study, "t", "mean-min-voi", plan, status="optimal", bound=v * (1 + 1e-3))
    assert r.status == "feasible" and r.gap == pytest.approx(1e-3 / (1 + 1e-3))
    r = Result.from_plan(case_study, "t", "mean-min-voi", plan, status="optimal", bound=v * (1 + 1e-8))
    assert r.status == "optimal"
    r = Result.from_plan(case_study, "t", "mean-min-voi", plan, status="optimal")
    assert r.status == "feasible"


def test_bound_worse_than_the_plan_is_a_bug(case_study, plan):
    v = voiopt.evaluate(case_study, plan)["mean-min-voi"]
    with pytest.raises(RuntimeError, match="worse than the simulated value"):
        Result.from_plan(case_study, "t", "mean-min-voi", plan, status="optimal", bound=v * 0.99)
    a = voiopt.evaluate(case_study, plan)["max-aoi"]
    with pytest.raises(RuntimeError):
        Result.from_plan(case_study, "t", "max-aoi", plan, status="optimal", bound=a + 1)
    # within tolerance the bound is clamped to the value: an exact tie
    r = Result.from_plan(case_study, "t", "mean-min-voi", plan, status="optimal", bound=v * (1 - 1e-9))
    assert r.bound == r.value and r.gap == 0 and r.status == "optimal"


def test_aoi_gap_is_relative_to_the_lower_bound(case_study, plan):
    r = Result.from_plan(case_study, "t", "max-aoi", plan, status="time_limit", bound=8)
    assert r.gap == pytest.approx((12 - 8) / 8)


def test_round_trip_is_lossless_and_atomic(tmp_path, case_study, plan):
    r = Result.from_plan(case_study, "t", "mean-max-aoi", plan, status="feasible", runtime_s=0.25, solver={"nodes": 3, "x": float("inf")})
    path = tmp_path / "sub" / "r.json"
    r.save(path)
    assert os.listdir(path.parent) == ["r.json"], "no temporary file left behind"
    back = load_result(path)
    assert back.to_dict() == r.to_dict()
    assert back.plan == r.plan and back.value == r.value
    assert json.loads(path.read_text())["solver"]["x"] == "inf"
    assert voiopt.evaluate(case_study, json.loads(path.read_text())) == r.metrics


def test_failed_write_leaves_the_old_file(tmp_path, case_study, plan):
    path = tmp_path / "r.json"
    Result.from_plan(case_study, "t", "min-voi", plan, status="feasible").save(path)
    before = path.read_text()
    bad = Result.from_plan(case_study, "t", "min-voi", plan, status="feasible", solver={"obj": object()})
    with pytest.raises(TypeError):
        bad.save(path)
    assert path.read_text() == before
    assert os.listdir(tmp_path) == ["r.json"]


def test_plan_from_indices_round_trips(case_study, plan):
    from voiopt.core.simulate import check_plan

    idx, sched = check_plan(case_study, plan)
    assert Plan.from_indices(case_study, idx, sched) == plan


@pytest.mark.parametrize("gap,shown", [(None, "-"), (0.0, "0 %"), (1.357e-16, "0 %"), (-3e-16, "0 %"),
                                       (6.44e-4, "0.0644 %"), (0.3361, "33.61 %"), (2e-9, "2e-07 %")])
def test_a_gap_is_shown_as_a_percentage_and_rounding_noise_as_zero(gap, shown):
    assert objectives.show_gap(gap, 4) == shown


def test_the_summary_of_a_proven_optimum_shows_no_rounding_noise_as_its_gap(case_study):
    r = voiopt.solve(case_study, method="dp", objective="mean-min-voi")
    assert r.status == "optimal" and r.gap is not None and r.gap < objectives.GAP_NOISE
    assert "gap 0 %" in r.summary()


def test_the_summary_shows_a_long_start_up_beside_the_runtime():
    """The first fleet dp solve after installing printed '(2.45 s)' and took 19 s: numba's
    compilation, in solver['startup_s'], is outside runtime_s (a newcomer probe)."""
    r = voiopt.solve(voiopt.case_study(), method="greedy")
    assert r.summary().endswith(f"({r.runtime_s:.2f} s)")
    r.solver["startup_s"] = 13.6
    assert r.summary().endswith(f"({r.runtime_s:.2f} s; start-up 13.6 s)")
    r.solver["startup_s"] = 0.3  # numba's cache loaded: not worth a word
    assert r.summary().endswith(f"({r.runtime_s:.2f} s)")
