"""dp for two robots (MODEL.md section 10, docs/dp.md "Several robots"): optimal on every tiny
fleet by the oracle's brute force, on larger ones by an exact state-merging programme over
the oracle's own joint transitions; declines in one line what it cannot hold; stops on time."""

from __future__ import annotations

import copy
import functools
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time

import pytest
from conftest import ROOT, fleet_instances, undecided
from oracles import model_oracle as oracle

import voiopt
from voiopt.core.instance import from_dict
from voiopt.errors import OptionError
from voiopt.solvers.dp import fleet as fleet_dp
from voiopt.solvers.labels import fleet_search

CASES = fleet_instances()
OBJECTIVES = list(oracle.OBJECTIVES)


def brute_force_all(d: dict) -> dict[str, float]:
    """The oracle's brute force, every objective from one enumeration of the legal plans."""
    inst = oracle._parse(d)
    best: dict[str, float] = {}
    for trajs in oracle._iter_trajs(inst):
        for ob, v in oracle._evaluate(inst, trajs).items():
            if ob not in best or (v > best[ob] if oracle.OBJECTIVES[ob] else v < best[ob]):
                best[ob] = v
    return best


def merged_optimum(d: dict, objective: str, rules: bool = True) -> float:
    """The optimum by a forward programme over the exact joint state (points, moves used, every
    sensor's AoI and distance), merging equal states and keeping the best value so far: no
    dominance and no bounds, on the oracle's transitions. ``rules=False`` keeps each robot's
    own rules but drops those between robots (shared points, swaps, a sensor to two robots;
    then the nearer robot's distance counts)."""
    inst = oracle._parse(d)
    cur, used, dists = oracle._start_state(inst)
    K, T, N = len(inst.robots), inst.T, len(inst.sensors)
    alone = []
    for r in inst.robots:
        one = copy.copy(inst)
        one.robots = [r]
        alone.append(one)
    per_slot, by_aoi = objective.startswith("mean"), objective.endswith("aoi")

    @functools.cache
    def uploads(cur):
        if rules:
            return list(oracle._joint_uploads(inst, cur))
        return list(oracle.itertools.product(*[[u for (u,) in oracle._joint_uploads(alone[k], (cur[k],))]
                                               for k in range(K)]))

    @functools.cache
    def moves(t, cur, used):
        if t == T - 1:
            return [(cur, used)]
        if rules:
            out = list(oracle._joint_moves(inst, dists, t, cur, used))
        else:
            each = [list(oracle._joint_moves(alone[k], [dists[k]], t, (cur[k],), (used[k],))) for k in range(K)]
            out = [(tuple(m[0][0] for m in combo), tuple(m[1][0] for m in combo))
                   for combo in oracle.itertools.product(*each)]
        # the moves used matter only under a budget: elsewhere 0, so equal states merge
        return [(p2, tuple(u if r.max_moves is not None else 0 for u, r in zip(u2, inst.robots, strict=True)))
                for p2, u2 in out]

    voi = functools.cache(lambda i, a, q: oracle._voi(inst, i, a, q))
    layer = {(cur, used, tuple(s.a0 for s in inst.sensors), tuple(s.q0 for s in inst.sensors)):
             0.0 if per_slot else math.inf}
    for t in range(T):
        nxt = {}
        for (cur, used, aoi, q), acc in layer.items():
            for up in uploads(cur):
                a2, q2 = [a + 1 for a in aoi], list(q)
                for k, u in enumerate(up):
                    if u is not None:  # (the AoI objectives need no distances)
                        dist = 0.0 if by_aoi else inst.distance(cur[k], u)
                        q2[u] = min(q2[u], dist) if a2[u] == 1 else dist
                        a2[u] = 1
                w = -max(a2) if by_aoi else min(voi(i, a2[i], q2[i]) for i in range(N))
                acc2 = acc + w if per_slot else min(acc, w)
                for p2, u2 in moves(t, cur, used):
                    key = (p2, u2, tuple(a2), tuple(q2))
                    if acc2 > nxt.get(key, -math.inf):
                        nxt[key] = acc2
        layer = nxt
    best = max(layer.values())
    value = best / T if per_slot else best
    return -value if by_aoi else value


def fleet(N, T, size, seed, starts, ends=None, **fields):
    d = voiopt.generate(N, T, width=size, height=size, seed=seed, name=f"fleet-{N}-{T}-{seed}").to_dict()
    del d["start"]
    d["robots"] = [{"start": list(s)} for s in starts]
    for r, e in zip(d["robots"], ends or [], strict=False):
        r["end"] = list(e)
    d.update(fields)
    return from_dict(d)


@pytest.fixture(scope="module")
def optima():
    return {inst.name: brute_force_all(inst.to_dict()) for inst in CASES}


@pytest.mark.parametrize("inst", CASES, ids=lambda i: i.name)
def test_dp_is_optimal_on_every_tiny_fleet(inst, optima):
    for ob in OBJECTIVES:
        r = voiopt.solve(inst, method="dp", objective=ob)
        want = optima[inst.name][ob]
        assert r.status == "optimal", (ob, r.solver)
        assert r.value == pytest.approx(want, rel=1e-9, abs=1e-300), ob
        assert r.bound == pytest.approx(want, rel=1e-6, abs=1e-300), ob
        assert r.plan.to_dict()["robots"] and len(r.plan.robots) == 2


def test_rules_between_robots_bind_in_the_fixture(optima):
    """Without the rules between robots the optimum is strictly better in some (case,
    objective) pairs: a dp that ignored them would fail the test above. The state-merging
    programme with the rules agrees with the brute force, so it can serve as the reference
    where the brute force is too slow."""
    binding = 0
    for inst in CASES:
        d = inst.to_dict()
        for ob in OBJECTIVES:
            exact = merged_optimum(d, ob)
            assert exact == pytest.approx(optima[inst.name][ob], rel=1e-12, abs=1e-300)
            relaxed = merged_optimum(d, ob, rules=False)
            better = relaxed > exact if oracle.OBJECTIVES[ob] else relaxed < exact
            worse = exact > relaxed if oracle.OBJECTIVES[ob] else exact < relaxed
            assert not worse or math.isclose(exact, relaxed, rel_tol=1e-12), (inst.name, ob)  # a relaxation
            binding += better and not math.isclose(exact, relaxed, rel_tol=1e-12)
    assert binding >= 3


def test_the_swap_rule_changes_the_optimum():
    """Two robots exchange places on a 2 x 2 grid, each a sensor in range of its own end only.
    A swap would do it in one slot; without swaps robot 1 goes round the square and reaches
    sensor 1 two slots later. dp agrees with the brute force, and the relaxed optimum (swaps
    allowed) is strictly better, so the test sees a dp that allowed swaps."""
    d = {"area": {"width": 1, "height": 1}, "step": 1, "horizon": 4, "channel": {"d_th": 0.4},
         "robots": [{"start": [0, 0], "end": [1, 0]}, {"start": [1, 0], "end": [0, 0]}],
         "sensors": [{"position": [1, 0], "rho": 0.5}, {"position": [0, 0], "rho": 0.6}]}
    inst = from_dict(d)
    best = brute_force_all(d)
    for ob in OBJECTIVES:
        r = voiopt.solve(inst, method="dp", objective=ob)
        assert r.status == "optimal" and r.value == pytest.approx(best[ob], rel=1e-9), ob
        relaxed = merged_optimum(d, ob, rules=False)
        assert relaxed > best[ob] if oracle.OBJECTIVES[ob] else relaxed < best[ob], ob


LARGER = [
    dict(N=3, T=5, size=2, seed=1, starts=[(0, 0), (2, 2)]),
    dict(N=3, T=6, size=2, seed=2, starts=[(0, 0), (1, 0)], ends=[(2, 2), (0, 2)]),
    dict(N=3, T=5, size=2, seed=3, starts=[(1, 1), (0, 1)], blocked=[[1, 0]]),
]


@pytest.mark.parametrize("spec", LARGER, ids=lambda s: f"N{s['N']}-T{s['T']}-seed{s['seed']}")
def test_dp_is_optimal_on_3x3_fleets(spec):
    inst = fleet(**spec)
    d = inst.to_dict()
    for ob in OBJECTIVES:
        r = voiopt.solve(inst, method="dp", objective=ob)
        assert r.status == "optimal", ob
        assert r.value == pytest.approx(merged_optimum(d, ob), rel=1e-9, abs=1e-300), ob


def test_budgets_per_robot_are_kept():
    inst = fleet(3, 6, 2, 4, [(0, 0), (2, 2)], ends=[(0, 0), (2, 2)])
    d = inst.to_dict()
    d["robots"][0]["max_moves"], d["robots"][1]["max_moves"] = 2, 4
    inst = from_dict(d)
    for ob in OBJECTIVES:
        r = voiopt.solve(inst, method="dp", objective=ob)
        assert r.status == "optimal"
        assert r.value == pytest.approx(merged_optimum(d, ob), rel=1e-9, abs=1e-300), ob
        moves = [sum(a != b for a, b in zip(p.positions, p.positions[1:], strict=False)) for p in r.plan.robots]
        assert moves[0] <= 2 and moves[1] <= 4


def test_declines_three_robots_in_one_line():
    d = CASES[0].to_dict()
    d["area"] = {"width": 3, "height": 3}
    d["robots"] = [{"start": [0, 0]}, {"start": [1, 0]}, {"start": [2, 0]}]
    with pytest.raises(OptionError, match=r"at most 2 robots \(the instance has 3\)"):
        voiopt.solve(from_dict(d), method="dp", objective="min-voi")


def big_fleet() -> dict:
    d = fleet(4, 100, 30, 1, [(0, 0), (30, 30)]).to_dict()
    d["robots"][0]["max_moves"] = d["robots"][1]["max_moves"] = 80
    return d


def test_declines_a_product_state_over_the_memory_limit():
    with pytest.raises(OptionError, match=r"joint state of 2 robots on 961 points .* over --memory-limit 4"):
        voiopt.solve(from_dict(big_fleet()), method="dp", objective="min-voi")
    with pytest.raises(OptionError, match="over --memory-limit 0.001"):
        voiopt.solve(fleet(4, 20, 5, 1, [(0, 0), (5, 5)]), method="dp", objective="min-voi", memory_limit=0.001)


def test_cli_declines_with_exit_2_and_one_line(tmp_path):
    (tmp_path / "big.json").write_text(json.dumps(big_fleet()))
    run = subprocess.run([sys.executable, "-m", "voiopt", "solve", str(tmp_path / "big.json"), "--method", "dp"],
                         capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "joint state" in lines[0] and "Traceback" not in run.stderr


def test_time_limit_stops_with_a_legal_plan():
    inst = fleet(6, 30, 5, 3, [(0, 0), (5, 5)])
    fleet_dp.warm_up()
    t0 = time.perf_counter()
    r = voiopt.solve(inst, method="dp", objective="mean-min-voi", time_limit=1.0, beam=0)
    elapsed = time.perf_counter() - t0
    assert r.status == "time_limit" and elapsed < 2.0
    assert voiopt.evaluate(inst, r.plan)["mean-min-voi"] == r.value  # legal, and its value is the simulator's
    assert r.bound is None or r.bound >= r.value
    r = voiopt.solve(inst, method="dp", objective="min-voi", time_limit=1e-6)  # stopped before any search:
    assert r.status == "time_limit" and "the plan is greedy's, stopped at once" in r.solver["note"]  # greedy's plan
    assert voiopt.evaluate(inst, r.plan)["min-voi"] == r.value


def test_memory_limit_and_ctrl_c_stop_with_a_legal_plan():
    """A memory limit the product state fits but the labels do not, and a Ctrl-C during the
    search: each stops with its status and a legal plan (the simulator checks it)."""
    inst = fleet(4, 15, 4, 3, [(0, 0), (4, 4)])
    limit = fleet_search.joint_bytes(inst) * 1.5 / 1e9
    r = voiopt.solve(inst, method="dp", objective="mean-min-voi", memory_limit=limit)
    assert r.status == "memory_limit" and r.solver["stopped"] == f"memory limit of {limit:g} GB reached"
    assert voiopt.evaluate(inst, r.plan)["mean-min-voi"] == r.value
    big = fleet(6, 30, 5, 3, [(0, 0), (5, 5)])
    fleet_dp.warm_up()
    timer = threading.Timer(1.5, os.kill, (os.getpid(), signal.SIGINT))  # after the pass for a legal plan
    t0 = time.perf_counter()
    timer.start()
    try:
        r = voiopt.solve(big, method="dp", objective="mean-min-voi", beam=0)
    finally:
        timer.cancel()
    assert r.status == "interrupted" and time.perf_counter() - t0 < 3.0
    assert voiopt.evaluate(big, r.plan)["mean-min-voi"] == r.value


def test_one_robot_options_are_refused_for_a_fleet():
    with pytest.raises(OptionError, match="--collapse: an option of the one-robot dp"):
        voiopt.solve(CASES[0], method="dp", objective="min-voi", collapse=False)


def test_no_legal_joint_plan_is_infeasible():
    """Ends that only a swap could reach, on a fleet the loader's check of joint plans leaves
    undecided (each robot alone can finish): the pass without uploads proves that none exists."""
    d = {"area": {"width": 1, "height": 0.0001}, "step": 1, "horizon": 3, "channel": {"d_th": 0.4},
         "robots": [{"start": [0, 0], "end": [1, 0]}, {"start": [1, 0], "end": [0, 0]}],
         "sensors": [{"position": [1, 0], "rho": 0.5}]}
    assert oracle.count_legal_plans(d) == 0
    r = voiopt.solve(undecided(d), method="dp", objective="min-voi")
    assert r.status == "infeasible" and r.plan is None


def test_a_limit_stops_the_build_of_the_tables_and_greedy_gives_the_plan():
    """Two robots at T = 1633: dp's value table W grows as T^2 and took 35 s, built without a
    look at the stop rule, past a 1.69 s limit (a fuzz campaign). Stopped there, the plan is
    greedy's, stopped at once, legal and valued by the simulator."""
    d = voiopt.generate(4, 1633, width=2.0, height=2.0, seed=67).to_dict()
    d.pop("start")
    d["robots"] = [{"start": [0.0, 2.0]}, {"start": [1.0, 1.0]}]
    r = voiopt.solve(from_dict(d), "dp", "min-voi", time_limit=0.3)
    assert r.status == "time_limit" and r.runtime_s <= 0.3 * 1.1 + 1, r.solver
    assert "stopped while building the tables" in r.solver["note"] and "greedy's" in r.solver["note"]
    assert r.value == pytest.approx(oracle.simulate(d, r.plan.to_dict())["min-voi"], rel=1e-12)


def test_a_limit_stops_the_legal_pass_and_greedy_gives_the_plan():
    """The pass without uploads, which finds dp's first legal joint plan, ran past any limit
    (a stop must return a plan): 0.35 s at paper scale, but 37 s for a 0.47 s limit on a 21 x 21
    factory floor at T = 131 (a fuzz campaign). dp now has greedy's plan, stopped at once, to
    return instead, so the pass follows the limit too."""
    inst = voiopt.generate_set(1, seed=1030, preset="factory", n_sensors=3, horizon=60, robots=2)[0]
    r = voiopt.solve(inst, "dp", "mean-min-voi", time_limit=0.3)
    assert r.status == "time_limit" and r.runtime_s <= 0.3 * 1.1 + 1, r.solver
    assert "legal joint plan" in r.solver["note"] and "greedy's" in r.solver["note"]
    d = inst.to_dict()
    assert r.value == pytest.approx(oracle.simulate(d, r.plan.to_dict())["mean-min-voi"], rel=1e-12)
