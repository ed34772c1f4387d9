"""shortest-path and greedy for several robots (MODEL.md section 10): legal, conflict-free plans
(checked by the independent oracle), never better than the oracle's optimum, deterministic,
and stopped by the usual limits. The generator's ``robots`` and ``dock`` options too."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from conftest import SWAP_ONLY, fleet_instances, oracle_optima, stop_at_check, undecided
from oracles import model_oracle as oracle

import voiopt
from voiopt.cli.main import main
from voiopt.core.instance import from_dict
from voiopt.networks import fields
from voiopt.solvers.baselines import fleet as fleet_baselines

CASES = fleet_instances()
METHODS = ("shortest-path", "greedy")


@pytest.mark.parametrize("method", METHODS)
def test_tiny_fleets_get_legal_plans_no_better_than_the_optimum(method):
    for inst in CASES:
        d = inst.to_dict()
        for ob, maximise in oracle.OBJECTIVES.items():
            r = voiopt.solve(inst, method, ob)
            assert r.status == "feasible", (inst.name, r.solver)
            assert r.value == pytest.approx(oracle.simulate(d, r.plan.to_dict())[ob], rel=1e-12)
            best = oracle_optima(inst)[ob]
            assert (r.value <= best * (1 + 1e-12)) if maximise else (r.value >= best)


def test_greedy_reaches_the_optimum_on_most_tiny_fleets():
    """A real check of the joint upload choice: greedy's mean-min-voi is optimal on most cases."""
    hits = sum(voiopt.solve(i, "greedy").value == pytest.approx(oracle_optima(i)["mean-min-voi"], rel=1e-9)
               for i in CASES)
    assert hits >= 9, hits


def _corridor(ends):
    d = {"area": {"width": 3, "height": 0.5}, "horizon": 6, "channel": {"d_th": 1.0},
         "robots": [{"start": [0, 0], "end": ends[0]}, {"start": [3, 0], "end": ends[1]}],
         "sensors": [{"position": [1, 0], "rho": 0.6}, {"position": [2, 0], "rho": 0.9}]}
    return d


@pytest.mark.parametrize("method", METHODS)
def test_a_corridor_makes_robots_give_way(method):
    """Robots that want each other's side of a corridor must never share a point or swap: with
    ends side by side it works out; with ends swapped no legal plan exists at all (the loader
    says so; past its size the methods prove it)."""
    d = _corridor([[1, 0], [2, 0]])
    r = voiopt.solve(from_dict(d), method)
    assert r.status == "feasible"
    oracle.simulate(d, r.plan.to_dict())
    swapped = _corridor([[3, 0], [0, 0]])
    assert oracle.count_legal_plans(swapped) == 0
    with pytest.raises(voiopt.VoioptError, match="robots: no legal joint plan"):
        from_dict(swapped)
    r = voiopt.solve(undecided(swapped), method)
    assert r.status == "infeasible" and r.plan is None and "no conflict-free joint plan" in r.solver["note"]


@pytest.mark.parametrize("kw", [dict(robots=2), dict(robots=3, dock=True, end="start"),
                                dict(robots=2, end="random", max_moves=12, blocked_fraction=0.2)])
def test_larger_fleets_are_legal_and_deterministic(kw):
    inst = voiopt.generate(8, 30, seed=11, **kw)
    d = inst.to_dict()
    for method in METHODS:
        for ob in ("mean-min-voi", "max-aoi"):
            a, b = voiopt.solve(inst, method, ob), voiopt.solve(inst, method, ob)
            assert a.plan == b.plan and a.status == "feasible"
            assert a.value == pytest.approx(oracle.simulate(d, a.plan.to_dict())[ob], rel=1e-12)


def test_greedy_with_two_robots_beats_one_on_average():
    """The second robot is used: over a few networks, two robots' greedy plan is better."""
    one = [voiopt.solve(voiopt.generate(10, 30, seed=s), "greedy").value for s in range(4)]
    two = [voiopt.solve(voiopt.generate(10, 30, seed=s, robots=2), "greedy").value for s in range(4)]
    assert np.mean(two) > np.mean(one)


@pytest.mark.parametrize("method", METHODS)
def test_a_stopped_fleet_heuristic_still_ends_legally(method):
    inst = fields.factory(20, seed=3, robots=3)
    r = voiopt.solve(inst, method, time_limit=0.02)
    assert r.status == "time_limit" and "head for their ends" in r.solver["stopped"]
    assert voiopt.evaluate(inst, r.plan)[r.objective] == r.value


def test_clusters_are_balanced_and_cover_every_sensor():
    inst = voiopt.generate(11, 10, seed=2, robots=3)
    groups = fleet_baselines.clusters(inst, list(range(11)))
    assert sorted(i for g in groups for i in g) == list(range(11))
    assert max(map(len, groups)) <= 4


def test_generator_robots_and_dock(tmp_path):
    one = voiopt.generate(6, 20, seed=5)
    two = voiopt.generate(6, 20, seed=5, robots=2)
    assert two.fleet[0].start == one.start and two.sensors == one.sensors  # robot 0 is the one-robot network's
    docked = voiopt.generate(6, 20, seed=5, robots=3, dock=True, end="start")
    starts = [r.start for r in docked.fleet]
    assert len(set(starts)) == 3 and all(r.end == r.start for r in docked.fleet)
    assert max(abs(a - b) + abs(c - e) for (a, c) in starts for (b, e) in starts) <= 2  # around the dock
    factory = fields.factory(12, seed=1, robots=2)
    assert [r.start for r in factory.fleet] == [(0.0, 0.0), (0.0, 1.0)]
    assert main(["generate", "--sensors", "5", "--robots", "2", "--dock", "--end", "start", "--out", str(tmp_path)]) == 0
    path = next(tmp_path.glob("*.json"))
    assert len(json.loads(path.read_text())["robots"]) == 2
    assert main(["solve", str(path), "--method", "greedy", "-o", str(tmp_path / "r.json")]) == 0
    assert main(["evaluate", str(path), str(tmp_path / "r.json")]) == 0
    assert main(["generate", "--robots", "0"]) == 2
    assert main(["solve", str(path), "--method", "beam"]) == 2


def test_the_shipped_fleet_example_is_what_the_readme_says():
    from conftest import ROOT

    inst = voiopt.load(ROOT / "instances" / "fleet.json")
    assert (inst.n_robots, inst.n_sensors, inst.horizon) == (2, 5, 15)
    assert all(r.end == r.start and r.max_moves == 10 for r in inst.robots)
    assert abs(inst.robots[0].start[0] - inst.robots[1].start[0]) + abs(inst.robots[0].start[1]
                                                                         - inst.robots[1].start[1]) == 1
    r = voiopt.solve(inst, "greedy")
    assert r.status == "feasible"
    assert r.value == pytest.approx(oracle.simulate(inst.to_dict(), r.plan.to_dict())["mean-min-voi"], rel=1e-12)


# From the review: robot 0 is drawn into a dead-end room (sensor 0) whose only door (4, 0) is
# robot 1's end, which robot 1 reaches with its whole budget. A legal joint plan exists, but
# greedy's walker spends its tries in the doomed subtree below the trap.
TRAP = {
    "name": "trap", "area": {"width": 6, "height": 1}, "horizon": 20,
    "robots": [{"start": [3, 1], "end": [0, 0]}, {"start": [0, 1], "end": [4, 0], "max_moves": 5}],
    "blocked": [[4, 1]],
    "sensors": [{"position": [6, 1], "rho": 0.3}, {"position": [4, 0.2], "rho": 0.5}],
}


def test_a_trapped_walker_falls_back_to_exact_legal_paths_and_never_claims_infeasible(monkeypatch):
    three = copy.deepcopy(TRAP)  # three robots: the joint table of states that can still finish
    three["area"]["height"] = 2
    three["robots"].append({"start": [0, 2]})
    for case, tries in ((TRAP, 2000), (three, 1)):  # two robots: dp's pass without uploads; three: given up at once
        monkeypatch.setattr(fleet_baselines, "MAX_TRIES", tries)
        r = voiopt.solve(from_dict(case), "greedy")
        assert r.status == "feasible" and "exactly found legal joint paths" in r.solver["walker"]
        assert r.value == pytest.approx(oracle.simulate(case, r.plan.to_dict())["mean-min-voi"], rel=1e-12)
        assert any(u is not None for robot in r.plan.robots for u in robot.schedule)  # uploads along the paths


def test_the_loader_and_exact_legal_paths_agree_with_the_oracle():
    """On random tiny fleets of 2 to 4 robots with ends and budgets, the loader rejects exactly
    the fleets with no legal plan (the oracle finds none) wherever it builds its table of joint
    points (voiopt.grid.joint.decides), saying why in one line; for the others fleet_mdp.legal_paths
    walks a plan the oracle finds legal."""
    from voiopt.grid import joint
    from voiopt.mdp import fleet as fleet_mdp

    rng = np.random.default_rng(8)
    seen = {"legal": 0, "rejected": 0, "no joint plan": 0, "undecided": 0}
    for trial in range(150):
        w, h, K = float(rng.choice([0.5, 0.75])), float(rng.choice([0.25, 0.5])), int(rng.choice([2, 3, 4]))
        pts = [[x * 0.25, y * 0.25] for x in range(int(w / 0.25) + 1) for y in range(int(h / 0.25) + 1)]
        robots = []
        for k in rng.choice(len(pts), size=K, replace=False):
            r = {"start": pts[k]}
            if rng.random() < 0.7:
                r["end"] = pts[rng.integers(len(pts))]
            if rng.random() < 0.4:
                r["max_moves"] = int(rng.integers(0, 4))
            robots.append(r)
        d = {"name": f"t{trial}", "area": {"width": w, "height": h}, "step": 0.25, "horizon": int(rng.integers(3, 7)),
             "robots": robots, "sensors": [{"position": [0.1, 0.1], "rho": 0.5}]}
        try:
            exists = next(oracle.legal_plans(d), None) is not None
        except oracle.OracleError:  # some robot alone cannot keep its end or budget
            exists = False
        fits = joint.decides(len(pts), K, d["horizon"], [r.get("max_moves") for r in robots])
        try:
            inst = from_dict(d)
        except voiopt.VoioptError as e:
            assert not exists and "\n" not in str(e), (d, str(e))
            seen["rejected"] += 1
            seen["no joint plan"] += "robots: no legal joint plan" in str(e)
            continue
        if not fits:
            seen["undecided"] += 1
            continue
        assert exists, d
        paths = fleet_mdp.legal_paths(inst)
        lat = voiopt.grid.lattice.build(inst.robot(0))
        plan = {"robots": [{"positions": [lat.points[p].tolist() for p in paths[k]], "schedule": [None] * inst.horizon}
                           for k in range(K)]}
        oracle.simulate(d, plan)  # raises if any rule is broken
        seen["legal"] += 1
        seen[f"legal, {K} robots"] = seen.get(f"legal, {K} robots", 0) + 1
    assert seen["legal"] >= 30 and seen["no joint plan"] >= 2 and seen["undecided"] >= 1, seen
    assert all(seen.get(f"legal, {K} robots", 0) >= 3 for K in (2, 3, 4)), str(seen)
    three = {**SWAP_ONLY, "robots": [*SWAP_ONLY["robots"], {"start": [2, 1]}]}  # two robots must still swap
    for d in (SWAP_ONLY, three):
        assert oracle.count_legal_plans(d) == 0
        with pytest.raises(voiopt.VoioptError, match="robots: no legal joint plan"):
            from_dict(d)
        with pytest.raises(joint.NoJointPlan):  # past the loader's check, legal_paths proves it too
            fleet_mdp.legal_paths(undecided(d))


@pytest.mark.parametrize("method", [*METHODS, "milp"])
def test_no_joint_plan_is_proved_within_the_time_limit(method):
    """Only a swap would let these robots pass (the oracle counts no legal plan): after the
    limit the walker stops backtracking, and dp's exact pass proves infeasibility."""
    import time

    assert oracle.count_legal_plans(SWAP_ONLY) == 0
    start = time.perf_counter()
    r = voiopt.solve(undecided(SWAP_ONLY), method, time_limit=0.5)
    assert r.status == "infeasible" and r.plan is None and "no legal joint plan" in r.solver["note"]
    assert time.perf_counter() - start < 0.5 + 5.0  # the limit holds (generously: dp may load its kernels)


@pytest.mark.parametrize("method", METHODS)
def test_a_lattice_packed_with_robots_gets_its_one_legal_plan_within_the_time_limit(method):
    """36 robots on 6 x 6 points: the only legal joint move is every robot staying. The
    walker's enumeration of joint moves is exponential there (it had not finished one slot
    after 11 minutes, and ignored the time limit and SIGTERM): it is cut after MAX_NODES
    partial choices, or by the stop rule, to every robot staying."""
    d = voiopt.generate(3, 4, seed=1).to_dict()
    d.pop("start")
    d["robots"] = [{"start": [float(x), float(y)]} for y in range(6) for x in range(6)]
    inst = from_dict(d)
    r = voiopt.solve(inst, method, "mean-min-voi", time_limit=3)
    assert r.status in ("feasible", "time_limit") and r.runtime_s <= 3 * 1.1 + 1
    assert r.value == pytest.approx(oracle.simulate(d, r.plan.to_dict())["mean-min-voi"], rel=1e-12)
    assert all(len(set(robot.positions)) == 1 for robot in r.plan.robots)


def test_a_walk_whose_joint_moves_were_cut_short_proves_nothing():
    """35 robots on 6 x 6 points, the robot beside the hole bound to end in it at T = 2: no
    robot may stay the whole plan, so the cut enumeration's one offer (everyone stays) fails.
    The walker then ran out of joint moves and called that a proof: greedy and milp (which
    trusts greedy's proofs) said infeasible (a review, 2026-12-02). A legal plan exists."""
    d = voiopt.generate(2, 2, seed=1).to_dict()
    d.pop("start")
    points = [(x, y) for y in range(6) for x in range(6) if (x, y) != (5, 5)]
    d["robots"] = [{"start": [float(x), float(y)], **({"end": [5.0, 5.0]} if (x, y) == (4, 5) else {})}
                   for x, y in points]
    inst = from_dict(d)
    legal = voiopt.solve(inst, "shortest-path")
    assert legal.status == "feasible"
    assert legal.value == pytest.approx(oracle.simulate(d, legal.plan.to_dict())["mean-min-voi"], rel=1e-12)
    greedy = voiopt.solve(inst, "greedy", time_limit=10)
    assert greedy.status != "infeasible", greedy.solver
    exact = voiopt.solve(inst, "milp", time_limit=30)
    assert exact.status == "optimal" and exact.value >= legal.value
    assert exact.value == pytest.approx(oracle.simulate(d, exact.plan.to_dict())["mean-min-voi"], rel=1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_a_stopped_walk_finishes_however_many_slots_are_left(method):
    """Once stopped, the robots head for their ends, one joint move per slot. The walker gave
    up after MAX_TRIES_STOPPED joint moves, counted from the stop, so a stop with more slots
    left than that (T = 1500, signalled in a fuzz campaign) ended with status error and no
    plan, where three robots or more make the exact fallback's table too large. The budgets
    now count only the tries beyond one per slot."""
    inst = voiopt.generate(4, fleet_baselines.MAX_TRIES_STOPPED + 100, seed=3, robots=3, end="start")
    r = voiopt.solve(inst, method, time_limit=1e-9)
    assert r.status == "time_limit" and r.plan is not None, r.solver
    d = inst.to_dict()
    assert r.value == pytest.approx(oracle.simulate(d, r.plan.to_dict())["mean-min-voi"], rel=1e-12)


@pytest.mark.parametrize("end", [None, "start"])
def test_a_stopped_walk_at_a_long_horizon_stops_within_the_limit(end):
    """Once stopped, robots at their ends (or with none) stay there to the last slot, filled in
    at once: at T = 10^5 the walk took 8 to 10 s after a 2 s limit, one joint move per slot
    (here T = 30,000: 2 to 3 s)."""
    inst = voiopt.generate(4, 30_000, seed=5, robots=3, end=end)
    r = voiopt.solve(inst, "greedy", time_limit=0.2)
    assert r.status == "time_limit" and r.runtime_s <= 0.2 * 1.1 + 1
    d = inst.to_dict()
    assert r.value == pytest.approx(oracle.simulate(d, r.plan.to_dict())["mean-min-voi"], rel=1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_a_robot_without_an_end_does_not_park_on_another_robots_end_once_stopped(method):
    """Once stopped, robots head for their ends. A change to prefer staying on ties parked a
    robot without an end on another robot's end for good: the walk then backtracked past its
    budget, and the stopped run ended with status error and no plan (a review, 2026-12-02)."""
    d = {"name": "f11", "area": {"width": 3, "height": 3}, "horizon": 6,
         "robots": [{"start": [3, 3]}, {"start": [2, 0]}, {"start": [3, 2], "end": [2, 3], "max_moves": 3},
                    {"start": [1, 0]}, {"start": [3, 0], "end": [3, 3]}],
         "sensors": [{"position": [2.497334008448843, 0.4843981796426374], "rho": 0.5}]}
    r = voiopt.solve(from_dict(d), method, time_limit=1e-9)
    assert r.status == "time_limit" and r.plan is not None, r.solver
    assert r.value == pytest.approx(oracle.simulate(d, r.plan.to_dict())["mean-min-voi"], rel=1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_a_stopped_walk_that_gives_up_falls_back_on_staying_at_the_dock(method, monkeypatch):
    """Stopped mid-walk, robots whose ways home block each other made the walker give up
    after MAX_TRIES_STOPPED wasted tries, and the run ended with status error and no plan,
    where every robot staying at its start (the dock, its end) is legal (a fuzz campaign on
    factory floors, 7 of 61 time-limited runs). Here the budget is -1, so any stopped walk
    that is not home at once gives up; the stop fires mid-walk."""

    monkeypatch.setattr(fleet_baselines, "MAX_TRIES_STOPPED", -1)
    stop_at_check(monkeypatch, 12)
    inst = voiopt.generate(4, 40, seed=3, robots=3, end="start")
    r = voiopt.solve(inst, method)
    assert r.status == "time_limit" and r.plan is not None, r.solver
    assert "staying" in r.solver["walker"]
    d = inst.to_dict()
    assert all(len(set(robot.positions)) == 1 for robot in r.plan.robots)
    assert r.value == pytest.approx(oracle.simulate(d, r.plan.to_dict())["mean-min-voi"], rel=1e-12)


def test_a_stopped_walk_that_cannot_get_home_soon_gives_up_within_its_grace(monkeypatch):
    """Robot 2's dock is the corner, robots 0 and 1 dock beside it and get home first. The
    stopped walk then went on one joint move per slot, wasting no tries, to the last slot
    (at T = 134,203 on a factory floor, 9 s past a 1.8 s limit) before it backtracked. Now it
    gives up GRACE_S after the stop (here 0.05 s) and the robots stay at their docks."""
    monkeypatch.setattr(fleet_baselines, "GRACE_S", 0.05)
    stop_at_check(monkeypatch, 12)
    d = {"name": "corner", "area": {"width": 4, "height": 4}, "horizon": 20_000,
         "robots": [{"start": [0, 1], "end": [0, 1], "max_moves": 40}, {"start": [1, 0], "end": [1, 0], "max_moves": 40},
                    {"start": [0, 0], "end": [0, 0], "max_moves": 40}],
         "sensors": [{"position": [4, 4], "rho": 0.3}, {"position": [3.5, 4], "rho": 0.5}, {"position": [4, 2], "rho": 0.6}]}
    r = voiopt.solve(from_dict(d), "shortest-path")
    assert r.status == "time_limit" and "staying" in r.solver["walker"], r.solver
    assert r.value == pytest.approx(oracle.simulate(d, r.plan.to_dict())["mean-min-voi"], rel=1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_a_stopped_walk_on_its_way_home_is_not_cut_by_the_grace(method, monkeypatch):
    """The grace after a stop (GRACE_S) is for walks that could have been home by now: a walk
    still on its robots' fewest moves home goes on (cut at 0.5 s, three robots on a winding
    181 x 181 floor ended in status error where the walk would have got home; a review). Here
    GRACE_S is 0, the stop fires early, and the ends are 20 moves away."""
    monkeypatch.setattr(fleet_baselines, "GRACE_S", 0.0)
    stop_at_check(monkeypatch, 12)
    d = {"name": "corridor", "area": {"width": 20, "height": 2}, "horizon": 60,
         "robots": [{"start": [0, 0], "end": [20, 0]}, {"start": [0, 1], "end": [20, 1]}, {"start": [0, 2], "end": [20, 2]}],
         "sensors": [{"position": [3, 1.5], "rho": 0.4}, {"position": [1, 0.5], "rho": 0.6}]}
    r = voiopt.solve(from_dict(d), method)
    assert r.status == "time_limit" and "walker" not in r.solver, r.solver
    assert r.value == pytest.approx(oracle.simulate(d, r.plan.to_dict())["mean-min-voi"], rel=1e-12)
