"""The information-relaxation bound (MODEL.md section 11): J*(w) is no lower than any policy's
realised value on w, scenario by scenario; with every upload available it is dp's lossless
optimum; the bound is capped by the lossless bound and labelled statistical."""

from __future__ import annotations

import numpy as np
import pytest
from oracles.expectimax import tiny

import voiopt
from voiopt.core.instance import from_dict
from voiopt.core.policy_value import run
from voiopt.core.scenarios import sample_scenarios
from voiopt.core.simulate import simulate
from voiopt.solvers.policy.relaxation import information_relaxation, scenario_optimum


@pytest.mark.parametrize("objective", ["mean-min-voi", "mean-max-aoi"])
def test_scenario_optimum_dominates_the_optimal_policy_scenario_by_scenario(objective):
    inst = from_dict(tiny(3, 3, 5, {"model": "bernoulli", "success": 0.5}))
    policy = voiopt.solve(inst, "policy-dp", objective).policy
    maximise = objective == "mean-min-voi"
    scen = sample_scenarios(inst, 40, seed=5)
    for u in scen:
        j = scenario_optimum(inst, objective, u)
        realised = simulate(inst, run(policy, u)).metrics[objective]
        assert (j >= realised - 1e-9 * abs(j)) if maximise else (j <= realised + 1e-9 * abs(j))
    ir = information_relaxation(inst, objective, scenarios=scen, lossless_bound=None)
    mc = np.mean([simulate(inst, run(policy, u)).metrics[objective] for u in scen])
    assert (ir["bound"] >= mc) if maximise else (ir["bound"] <= mc)
    assert ir["samples"] == 40 and ir["confidence"] == 0.95


@pytest.mark.parametrize("objective", ["mean-min-voi", "mean-max-aoi"])
def test_every_upload_available_is_the_lossless_optimum(objective):
    d = tiny(6, 3, 5, None)
    inst = from_dict(d | {"links": {"model": "bernoulli", "success": 0.5}})
    u = np.zeros((inst.horizon, inst.n_sensors))  # every upload succeeds in this scenario
    dp = voiopt.solve(from_dict(d), "dp", objective)
    assert scenario_optimum(inst, objective, u) == pytest.approx(dp.value, rel=1e-9)


def test_the_bound_is_capped_by_the_lossless_bound():
    inst = from_dict(tiny(2, 2, 4, {"model": "bernoulli", "success": 0.9}))
    free = information_relaxation(inst, "mean-min-voi", samples=20, seed=1)
    capped = information_relaxation(inst, "mean-min-voi", samples=20, seed=1, lossless_bound=free["mean"])
    assert capped["capped"] and capped["bound"] == free["mean"]
    assert not free["capped"] and free["bound"] > free["mean"]
