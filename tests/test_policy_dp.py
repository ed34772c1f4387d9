"""The exact optimal policy (--method policy-dp, MODEL.md section 11) against an independent
exhaustive expectimax written here from MODEL.md alone, on tiny instances; with success 1 it
is dp's lossless optimum; its saved policy acts as its table says."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

import voiopt
from voiopt.core.policy import Policy
from voiopt.core.policy_value import exact_value, monte_carlo_value
from voiopt.core.scenarios import sample_scenarios
from voiopt.errors import OptionError
from voiopt.instance import from_dict

MOVES = [(0, 0), (0, 1), (0, -1), (1, 0), (-1, 0)]


def tiny(seed: int, n: int, T: int, links: dict | None, **extra) -> dict:
    rng = np.random.default_rng(seed)
    sensors = []
    for _ in range(n):
        s = {"position": [float(rng.uniform(0, 2)), float(rng.uniform(0, 2))], "rho": float(rng.uniform(0.3, 0.9)),
             "initial_aoi": int(rng.integers(1, 4)), "initial_distance": float(rng.uniform(0.2, 1.0))}
        sensors.append(s)
    d = {"name": f"tiny{seed}", "area": {"width": 2, "height": 2}, "horizon": T,
         "start": [int(rng.integers(0, 3)), int(rng.integers(0, 3))], "sensors": sensors, **extra}
    if links is not None:
        d["links"] = links
    return d


def oracle(d: dict, objective: str) -> float:
    """Exhaustive expectimax over (slot, position, moves, A, q), from MODEL.md sections 1-5, 9, 11."""
    W, H, T = d["area"]["width"], d["area"]["height"], d["horizon"]
    ch = {"g0_db": -50.0, "bandwidth_hz": 2e6, "noise_dbm_per_hz": -110.0, "d_th": 1.0}
    g0, B = 10 ** (ch["g0_db"] / 10), ch["bandwidth_hz"]
    N0 = 10 ** (ch["noise_dbm_per_hz"] / 10) / 1000
    S = d["sensors"]
    links = d.get("links")
    end = tuple(d["end"]) if "end" in d else None
    budget = d.get("max_moves")

    def dist(pos, i):
        return math.hypot(pos[0] - S[i]["position"][0], pos[1] - S[i]["position"][1])

    def prob(i, dd):
        if links is None:
            return 1.0
        if "success" in S[i]:
            return S[i]["success"]
        if links["model"] == "bernoulli":
            return links["success"]
        gamma = 10 ** (links["snr_threshold_db"] / 10)
        return math.exp(-gamma * B * N0 * dd * dd / (S[i].get("power_w", 1.0) * g0))

    def voi(i, a, q):
        P = S[i].get("power_w", 1.0)
        x = P * g0 * S[i]["rho"] ** a / (B * N0 * q * q + P * g0)
        return -B * math.log1p(-x) / math.log(2)

    def reward(A, q):
        if objective == "mean-max-aoi":
            return -max(A)
        return min(voi(i, A[i], q[i]) for i in range(len(S)))

    def ok(pos, t, moves):
        if not (0 <= pos[0] <= W and 0 <= pos[1] <= H):
            return False
        if budget is not None and moves > budget:
            return False
        if end is not None:
            need = abs(pos[0] - end[0]) + abs(pos[1] - end[1])
            left = T - 1 - t if budget is None else min(T - 1 - t, budget - moves)
            return need <= left
        return True

    @functools.cache
    def best(t, pos, moves, A, q):
        if t == T:
            return 0.0
        out = -math.inf
        for u in [None] + [i for i in range(len(S)) if dist(pos, i) <= 1.0 + 1e-9]:
            for mv in MOVES if t < T - 1 else [(0, 0)]:
                nxt = (pos[0] + mv[0], pos[1] + mv[1])
                m2 = moves + (mv != (0, 0))
                if t < T - 1 and not ok(nxt, t + 1, m2):
                    continue
                A2 = tuple(a + 1 for a in A)
                branches = [(1.0, A2, q)]
                if u is not None:
                    p = prob(u, dist(pos, u))
                    As = tuple(1 if i == u else a for i, a in enumerate(A2))
                    qs = tuple(dist(pos, u) if i == u else x for i, x in enumerate(q))
                    branches = [(p, As, qs), (1.0 - p, A2, q)]
                v = sum(pr * (reward(a2, q2) + best(t + 1, nxt, m2, a2, q2)) for pr, a2, q2 in branches if pr > 0)
                out = max(out, v)
        return out

    A0 = tuple(s["initial_aoi"] for s in S)
    q0 = tuple(s["initial_distance"] for s in S)
    total = best(0, tuple(d["start"]), 0, A0, q0) / T
    return total if objective == "mean-min-voi" else -total


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
    assert r.policy.kind == "table"
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
    from voiopt.cli import main

    inst_path = tmp_path / "tiny.json"
    voiopt.save(from_dict(tiny(1, 2, 4, {"model": "bernoulli", "success": 0.6})), inst_path)
    out = tmp_path / "r.json"
    assert main(["solve", str(inst_path), "--method", "policy-dp", "-o", str(out), "--quiet"]) == 0
    result = voiopt.load_result(out)
    assert result.solver["policy_file"] == "r.policy.json"
    policy = Policy.load(tmp_path / "r.policy.json")
    assert exact_value(policy) == pytest.approx(result.value, rel=1e-12)


def test_stopped_by_the_memory_limit_returns_the_open_loop_plan_and_the_lossless_bound():
    d = voiopt.load("instances/case-study.json").to_dict() | {"links": {"model": "bernoulli", "success": 0.7}}
    inst = from_dict(d)
    r = voiopt.solve(inst, "policy-dp", "mean-min-voi", memory_limit=1e-3)
    assert r.status == "memory_limit" and r.bound_kind == "lossless" and r.evaluation == "exact"
    assert r.policy.kind == "plan" and r.plan is not None
    from voiopt.core.expectation import expected_metrics

    assert r.value == expected_metrics(inst, r.plan)["mean-min-voi"]
    assert r.value < r.bound
