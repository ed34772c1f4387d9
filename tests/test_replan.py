"""The re-planning policy (--method replan, MODEL.md section 11): valued exactly on tiny
instances, never above the optimal policy, the lossless optimum where every upload succeeds,
and Monte Carlo within its CI of the exact value."""

from __future__ import annotations

import pytest
from oracles.expectimax import oracle, tiny

import voiopt
from voiopt.core.instance import from_dict
from voiopt.core.policy_value import exact_value, monte_carlo_value
from voiopt.core.scenarios import sample_scenarios


@pytest.mark.parametrize("objective", ["mean-min-voi", "mean-max-aoi"])
@pytest.mark.parametrize("seed", [1, 3])
def test_replan_is_no_better_than_the_optimal_policy(seed, objective):
    d = tiny(seed, 3, 5, {"model": "bernoulli", "success": 0.5})
    inst = from_dict(d)
    r = voiopt.solve(inst, "replan", objective)
    best = oracle(d, objective)
    assert r.status == "feasible" and r.evaluation == "exact" and r.bound_kind == "lossless"
    assert (r.value <= best * (1 + 1e-9)) if objective == "mean-min-voi" else (r.value >= best * (1 - 1e-9))
    assert exact_value(r.policy, objective) == pytest.approx(r.value, rel=1e-12)


def test_replan_with_success_one_is_the_lossless_optimum():
    d = tiny(7, 3, 5, {"model": "bernoulli", "success": 1.0})
    r = voiopt.solve(from_dict(d), "replan", "mean-min-voi")
    assert r.value == pytest.approx(voiopt.solve(from_dict({k: v for k, v in d.items() if k != "links"}), "dp").value,
                                    rel=1e-9)


def test_replan_monte_carlo_within_its_ci_of_exact():
    inst = from_dict(tiny(2, 2, 5, {"model": "rayleigh", "snr_threshold_db": 28.0}))
    r = voiopt.solve(inst, "replan", "mean-min-voi")
    est = monte_carlo_value(r.policy, sample_scenarios(inst, 300, seed=2))
    assert est.ci[0] <= r.value <= est.ci[1]


def test_replan_with_an_information_relaxation_bound_says_so():
    inst = from_dict(tiny(4, 2, 4, {"model": "bernoulli", "success": 0.3}))
    r = voiopt.solve(inst, "replan", "mean-min-voi", ir_samples=30, seed=1)
    assert r.bound_kind == "information-relaxation"  # here far below the lossless bound (half of it)
    assert r.bound_samples == 30 and r.bound_confidence == 0.95
    assert r.value <= r.bound < r.solver["lossless_bound"]
    assert r.to_dict()["bound_kind"] == "information-relaxation" and r.status != "optimal"


def _slow_solves(monkeypatch, seconds):
    """Each re-plan takes ``seconds`` longer: a tiny instance with the cost of a large one."""
    import time

    from voiopt.solvers.policy.replan import ReplanPolicy

    real = ReplanPolicy._replan

    def slow(self, t, state):
        time.sleep(seconds)
        return real(self, t, state)

    monkeypatch.setattr(ReplanPolicy, "_replan", slow)


def test_replan_stopped_before_two_scenarios_keeps_the_open_loop_plan(monkeypatch):
    """Not even two scenarios in the time: the slot-0 plan, open-loop, valued exactly."""
    _slow_solves(monkeypatch, 0.2)
    inst = from_dict(tiny(2, 3, 5, {"model": "bernoulli", "success": 0.5}))
    r = voiopt.solve(inst, "replan", "mean-min-voi", time_limit=0.1)
    assert r.status == "time_limit" and r.policy.kind == "plan" and r.evaluation == "exact"
    assert r.bound_kind == "lossless" and r.value <= r.bound and "open-loop" in r.solver["note"]
    assert r.runtime_s < 5


def test_replan_cut_short_keeps_the_monte_carlo_over_the_scenarios_done(monkeypatch):
    """The exact enumeration gets half the time; the Monte Carlo keeps what it did in the
    rest, with its count, and the status names the limit; solves are counted."""
    _slow_solves(monkeypatch, 0.03)
    inst = from_dict(tiny(3, 3, 5, {"model": "bernoulli", "success": 0.5}))
    r = voiopt.solve(inst, "replan", "mean-min-voi", time_limit=1.0, samples=10_000)
    assert r.status == "time_limit" and r.evaluation == "monte-carlo" and 2 <= r.samples < 10_000
    assert r.policy.kind != "plan" and r.solver["solves"] > 0 and "Monte Carlo over" in r.solver["evaluation_note"]
    low, high = r.value_ci
    assert low <= r.value <= high and r.runtime_s < 5

