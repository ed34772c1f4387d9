"""The exact optimal policy (--method policy-dp, MODEL.md section 11) against an independent
exhaustive expectimax written from MODEL.md alone (tests/oracles/expectimax.py), on tiny instances; with success 1 it
is dp's lossless optimum; its saved policy acts as its table says."""

from __future__ import annotations

import pytest
from oracles.expectimax import oracle, tiny

import voiopt
from voiopt.core.instance import from_dict
from voiopt.core.policy import Policy
from voiopt.core.policy_value import exact_value, monte_carlo_value
from voiopt.core.scenarios import sample_scenarios
from voiopt.errors import OptionError

CASES = [
    (1, 2, 4, {"model": "bernoulli", "success": 0.6}, {}),
    (2, 3, 4, {"model": "bernoulli", "success": 0.35}, {}),
    (3, 2, 5, {"model": "rayleigh", "snr_threshold_db": 28.0}, {}),
    (4, 3, 4, {"model": "rayleigh", "snr_threshold_db": 27.0}, {"max_moves": 2}),
    (5, 2, 5, {"model": "bernoulli", "success": 0.8}, {"end": [0, 0], "max_moves": 3}),
]


@pytest.mark.parametrize("objective", ["mean-min-voi", "mean-max-aoi"])
@pytest.mark.parametrize(("seed", "n", "T", "links", "extra"), CASES)
def test_policy_dp_equals_exhaustive_expectimax(seed, n, T, links, extra, objective):
    d = tiny(seed, n, T, links, **extra)
    if seed == 2:
        d["sensors"][0]["success"] = 0.9  # a sensor's own probability overrides the model's
    inst = from_dict(d)
    r = voiopt.solve(inst, "policy-dp", objective)
    want = oracle(d, objective)
    assert r.status == "optimal" and r.evaluation == "exact" and r.bound_kind == "exact"
    assert r.value == pytest.approx(want, rel=1e-9)
    assert r.bound == pytest.approx(want, rel=1e-9)
    assert r.policy.kind == "table" and r.solver["search"] == "layered"
    lossless_bound = r.solver["lossless"]["bound"]
    assert (r.value <= lossless_bound * (1 + 1e-9)) if objective == "mean-min-voi" else (r.value >= lossless_bound * (1 - 1e-9))


@pytest.mark.parametrize("objective", ["mean-min-voi", "mean-max-aoi"])
@pytest.mark.parametrize("seed", [6, 7])
def test_success_one_is_the_lossless_optimum(seed, objective):
    d = tiny(seed, 3, 5, {"model": "bernoulli", "success": 1.0})
    inst = from_dict(d)
    r = voiopt.solve(inst, "policy-dp", objective)
    dp = voiopt.solve(from_dict({k: v for k, v in d.items() if k != "links"}), "dp", objective)
    assert r.status == "optimal" and dp.status == "optimal"
    assert r.value == pytest.approx(dp.value, rel=1e-9)


def test_bottleneck_objectives_are_refused_in_one_line():
    inst = from_dict(tiny(1, 2, 3, {"model": "bernoulli", "success": 0.5}))
    for objective in ("min-voi", "max-aoi"):
        with pytest.raises(OptionError, match="running extreme"):
            voiopt.solve(inst, "policy-dp", objective)


def test_saved_policy_acts_the_same_and_has_the_same_value(tmp_path):
    inst = from_dict(tiny(3, 3, 5, {"model": "bernoulli", "success": 0.5}))
    r = voiopt.solve(inst, "policy-dp", "mean-min-voi")
    path = tmp_path / "p.json"
    r.policy.save(path)
    loaded = Policy.load(path)
    assert exact_value(loaded) == pytest.approx(r.value, rel=1e-12)
    obs = {"slot": 0, "position": list(inst.start), "aoi": [s.initial_aoi for s in inst.sensors],
           "distance": [inst.initial_distance(i) for i in range(inst.n_sensors)]}
    assert loaded.act(obs) == r.policy.act(obs)
    assert loaded.act(obs).move in ("stay", "N", "S", "E", "W")


def test_unseen_observation_gets_a_legal_fallback():
    inst = from_dict(tiny(4, 2, 4, {"model": "bernoulli", "success": 0.5}))
    policy = voiopt.solve(inst, "policy-dp", "mean-max-aoi").policy
    obs = {"slot": 1, "position": list(inst.start), "aoi": [50, 60], "distance": [0.5, 0.5]}
    t, state = policy.observed(obs)
    assert policy.key(t, state) not in policy.table
    u, m = policy.choose(t, state)
    assert policy.steps.legal(t, state, u, m) is not None


def test_monte_carlo_agrees_with_exact_within_its_ci():
    inst = from_dict(tiny(2, 3, 5, {"model": "bernoulli", "success": 0.5}))
    r = voiopt.solve(inst, "policy-dp", "mean-min-voi")
    est = monte_carlo_value(r.policy, sample_scenarios(inst, 400, seed=11))
    assert est.count == 400
    assert est.ci[0] <= r.value <= est.ci[1]


def test_cli_saves_the_policy_beside_the_result(tmp_path, capsys):
    from voiopt.cli.main import main

    inst_path = tmp_path / "tiny.json"
    voiopt.save(from_dict(tiny(1, 2, 4, {"model": "bernoulli", "success": 0.6})), inst_path)
    out = tmp_path / "r.json"
    assert main(["solve", str(inst_path), "--method", "policy-dp", "-o", str(out), "--quiet"]) == 0
    result = voiopt.load_result(out)
    assert result.solver["policy_file"] == "r.policy.json"
    policy = Policy.load(tmp_path / "r.policy.json")
    assert exact_value(policy) == pytest.approx(result.value, rel=1e-12)


def test_stopped_by_the_memory_limit_returns_the_open_loop_plan_and_the_lossless_bound():
    d = voiopt.load("instances/case-study.json").to_dict() | {"horizon": 12, "links": {"model": "bernoulli", "success": 0.7}}
    inst = from_dict(d)
    r = voiopt.solve(inst, "policy-dp", "mean-min-voi", memory_limit=1e-3)
    assert r.status == "memory_limit" and r.bound_kind == "lossless" and r.evaluation == "exact"
    assert r.policy.kind == "plan" and r.plan is not None
    from voiopt.core.expectation import expected_metrics

    assert r.value == expected_metrics(inst, r.plan)["mean-min-voi"]
    assert r.value < r.bound
