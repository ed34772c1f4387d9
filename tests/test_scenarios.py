"""Coupled outcome scenarios and Monte Carlo (voiopt.core.scenarios, MODEL.md section 11): the
coupling rule, determinism in the seed, and Monte Carlo agreeing with the exact expectation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import voiopt
from voiopt.core.expectation import expected_metrics
from voiopt.core.instance import from_dict
from voiopt.core.links import success_probability
from voiopt.core.scenarios import estimate, monte_carlo, realise, sample_scenarios
from voiopt.errors import OptionError
from voiopt.grid import lattice


def lossy(inst, links=None):
    return from_dict(inst.to_dict() | {"links": links or {"model": "bernoulli", "success": 0.6}})


@pytest.fixture(scope="module")
def case():
    inst = voiopt.load("instances/case-study.json")
    plan = voiopt.solve(inst, method="greedy").plan
    return lossy(inst, {"model": "rayleigh", "snr_threshold_db": 27.5}), plan


def test_scenarios_are_uniforms_deterministic_in_the_seed(case):
    inst, _ = case
    a = sample_scenarios(inst, 50, seed=3)
    assert a.shape == (50, inst.horizon, inst.n_sensors) and a.dtype == np.float64
    assert ((0 <= a) & (a < 1)).all()
    assert np.array_equal(a, sample_scenarios(inst, 50, seed=3))
    assert not np.array_equal(a, sample_scenarios(inst, 50, seed=4))
    assert np.array_equal(a[:20], sample_scenarios(inst, 20, seed=3))


def test_coupling_an_upload_succeeds_iff_u_below_p(case):
    inst, plan = case
    lat = lattice.build(inst)
    for u in sample_scenarios(inst, 40, seed=1):
        got = realise(inst, plan, u)
        for t, (xy, i) in enumerate(zip(plan.positions, plan.schedule, strict=True)):
            if i is None:
                assert got.schedule[t] is None
                continue
            p = success_probability(inst, i, float(lat.distance[i, lat.index(*xy)]))
            assert got.schedule[t] == (i if u[t, i] < p else None)
        assert got.positions == plan.positions


@settings(max_examples=30, deadline=None, derandomize=True, database=None)
@given(st.integers(0, 9), st.floats(0, 1, exclude_max=True))
def test_coupling_at_the_edge(t, level):
    """U exactly at p fails, just below succeeds (success iff U < p)."""
    inst = lossy(voiopt.load("instances/case-study.json"), {"model": "bernoulli", "success": 0.5})
    plan = voiopt.solve(voiopt.load("instances/case-study.json"), method="greedy").plan
    u = np.full((inst.horizon, inst.n_sensors), level)
    got = realise(inst, plan, u).schedule
    want = tuple(s if level < 0.5 else None for s in plan.schedule)
    assert got == want
    u[:, :] = 0.5
    assert all(s is None for s in realise(inst, plan, u).schedule)
    u[:, :] = np.nextafter(0.5, 0)
    assert realise(inst, plan, u).schedule == plan.schedule


@pytest.mark.parametrize("objective", ["min-voi", "mean-min-voi", "max-aoi", "mean-max-aoi"])
def test_monte_carlo_of_a_plan_agrees_with_its_exact_expectation(case, objective):
    inst, plan = case
    exact = expected_metrics(inst, plan)[objective]
    est = monte_carlo(inst, plan, sample_scenarios(inst, 2000, seed=7), objective)
    assert est.count == 2000
    low, high = est.ci
    assert low < est.mean < high
    assert low <= exact <= high


def test_monte_carlo_of_a_run_function_equals_that_of_the_plan(case):
    inst, plan = case
    scen = sample_scenarios(inst, 30, seed=2)
    direct = monte_carlo(inst, plan, scen, "mean-min-voi")
    via_run = monte_carlo(inst, lambda u: realise(inst, plan, u), scen, "mean-min-voi")
    assert direct == via_run


def test_monte_carlo_of_a_fleet_plan_agrees_with_its_exact_expectation():
    inst = voiopt.load("instances/fleet.json")
    plan = voiopt.solve(inst, method="greedy").plan
    inst = lossy(inst, {"model": "bernoulli", "success": 0.4})
    exact = expected_metrics(inst, plan)["mean-min-voi"]
    est = monte_carlo(inst, plan, sample_scenarios(inst, 1000, seed=5), "mean-min-voi")
    assert est.ci[0] <= exact <= est.ci[1]


def test_estimate_is_the_student_t_interval():
    est = estimate([1.0, 2.0, 3.0, 4.0])
    half = 3.182446305284263 * np.std([1, 2, 3, 4], ddof=1) / 2  # t_{0.975, 3}
    assert est.mean == 2.5 and est.count == 4
    assert est.ci == pytest.approx((2.5 - half, 2.5 + half), rel=1e-12)
    assert estimate([5.0, 5.0]).ci == (5.0, 5.0)


@pytest.mark.parametrize("count,seed", [(0, 1), (2.5, 1), (True, 1), (3, -1), (3, "x")])
def test_bad_sampling_arguments_are_option_errors(case, count, seed):
    with pytest.raises(OptionError):
        sample_scenarios(case[0], count, seed)


def test_bad_scenarios_are_option_errors(case):
    inst, plan = case
    with pytest.raises(OptionError, match="scenarios"):
        monte_carlo(inst, plan, np.zeros((1, inst.horizon, inst.n_sensors)), "min-voi")
    with pytest.raises(OptionError, match="u_row"):
        realise(inst, plan, np.zeros((inst.horizon + 1, inst.n_sensors)))


def test_a_stop_ends_monte_carlo_with_the_scenarios_done(case):
    from voiopt.runtime.stop import Stop, Stopped

    inst, plan = case
    scen = sample_scenarios(inst, 50, seed=9)
    stop, runs = Stop(), []

    def run(u):
        runs.append(1)
        if len(runs) == 5:
            stop.request()
        return realise(inst, plan, u)

    est = monte_carlo(inst, run, scen, "mean-min-voi", stop=stop)
    assert est.count == 5 and est == monte_carlo(inst, plan, scen[:5], "mean-min-voi")
    stop = Stop()
    stop.request()
    with pytest.raises(Stopped):
        monte_carlo(inst, plan, scen, "mean-min-voi", stop=stop)
