"""Baselines: greedy and shortest path give legal, deterministic plans valued by the simulator;
the shortest closed walk is exactly shortest for small N (checked by an independent BFS)."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest
from conftest import tiny_instances
from oracles.bruteforce import brute_force

import voiopt
from voiopt.core.instance import from_dict
from voiopt.core.simulate import simulate
from voiopt.errors import OptionError
from voiopt.grid import lattice
from voiopt.solvers.baselines.heuristics import greedy, shortest_path


def _closed_walk_bfs(inst) -> int:
    """Fewest moves of a closed walk from start through the range of every servable sensor:
    BFS over (point, set of sensors served), written from MODEL.md with plain arithmetic."""
    step, dth = inst.step, inst.channel.d_th
    nx = int(math.floor(inst.width / step + 1e-9)) + 1
    ny = int(math.floor(inst.height / step + 1e-9)) + 1

    def near(k, l):
        return frozenset(i for i, s in enumerate(inst.sensors)
                         if math.hypot(k * step - s.position[0], l * step - s.position[1]) <= dth + 1e-9)

    servable = frozenset().union(*(near(k, l) for k in range(nx) for l in range(ny)))
    start = (round(inst.start[0] / step), round(inst.start[1] / step))
    first = (start, near(*start))
    seen, queue = {first: 0}, deque([first])
    while queue:
        (k, l), done = node = queue.popleft()
        if done == servable and (k, l) == start:
            return seen[node]
        for dk, dl in ((0, 1), (0, -1), (1, 0), (-1, 0)):
            if 0 <= k + dk < nx and 0 <= l + dl < ny:
                nxt = ((k + dk, l + dl), done | near(k + dk, l + dl))
                if nxt not in seen:
                    seen[nxt] = seen[node] + 1
                    queue.append(nxt)
    raise AssertionError("unreachable")


@pytest.mark.parametrize("inst", tiny_instances(8, seed=31) + [voiopt.generate(4, 30, seed=s) for s in range(4)],
                         ids=lambda i: i.name)
def test_shortest_closed_walk_is_exact_for_small_n(inst):
    r = shortest_path(inst, "mean-min-voi")
    assert r.solver["tour"] == "exact"
    assert r.solver["tour_length"] == _closed_walk_bfs(inst)


def test_shortest_path_follows_the_walk_cyclically_and_uploads_the_oldest_in_range():
    inst = voiopt.generate(4, 40, seed=8)
    r = shortest_path(inst, "max-aoi")
    lat = lattice.build(inst)
    traj = simulate(inst, r.plan)
    L = r.solver["tour_length"]
    assert L > 0 and r.plan.positions[:L] == r.plan.positions[L:2 * L]
    assert r.plan.positions[0] == inst.start and r.plan.positions[L] == inst.start
    for t, u in enumerate(r.plan.schedule):
        in_range = np.flatnonzero(lat.in_range[:, traj.positions[t]])
        if len(in_range) == 0:
            assert u is None
        else:
            assert u == in_range[np.argmax(traj.aoi[t, in_range])]
    served = {u for u in r.plan.schedule if u is not None}
    assert served == set(range(inst.n_sensors))


def test_shortest_path_heuristic_above_the_exact_limit_covers_every_sensor():
    inst = voiopt.generate(10, 80, seed=4)
    r = shortest_path(inst, "mean-min-voi")
    assert r.solver["tour"].startswith("heuristic")
    assert {u for u in r.plan.schedule if u is not None} == set(range(10))
    assert r.metrics == voiopt.evaluate(inst, r.plan)
    assert shortest_path(inst, "mean-min-voi").plan == r.plan


@pytest.mark.parametrize("inst", tiny_instances(12, seed=77), ids=lambda i: i.name)
def test_greedy_plans_are_legal_deterministic_and_never_beat_the_optimum(inst):
    for objective in voiopt.OBJECTIVES:
        r = greedy(inst, objective)
        assert r.status == "feasible" and r.metrics == voiopt.evaluate(inst, r.plan)
        assert greedy(inst, objective).plan == r.plan
        best, _ = brute_force(inst, objective)
        assert (r.value <= best * (1 + 1e-9)) if objective.endswith("voi") else (r.value >= best)


def test_greedy_goes_to_the_worst_sensor_and_keeps_it_fresh():
    # One sensor three moves away: greedy must walk there and then upload every slot.
    inst = from_dict({"name": "walk", "area": {"width": 4, "height": 1}, "horizon": 7, "start": [0, 0],
                      "sensors": [{"position": [4, 0], "rho": 0.5, "initial_aoi": 3}]})
    for objective in ("mean-min-voi", "mean-max-aoi"):
        r = greedy(inst, objective)
        assert r.plan.schedule == (None, None, None, 0, 0, 0, 0)
        assert r.value == pytest.approx(brute_force(inst, objective)[0], rel=1e-12)


def test_greedy_beats_shortest_path_on_the_case_study_min_voi(case_study):
    assert greedy(case_study, "min-voi").value > shortest_path(case_study, "min-voi").value


def test_bad_seed_is_an_option_error(case_study):
    with pytest.raises(OptionError, match="seed"):
        shortest_path(case_study, "min-voi", seed=-3)


def test_the_tour_s_point_choice_is_the_plain_dp_with_its_ties():
    """The exact choice of each sensor's point for a sensor order, one array operation a step
    (74 s for seven sensors on a 3 x 3 lattice before, a class built per distance asked; a
    fuzz campaign), against the plain DP over points in turn, ties to the first point."""
    import itertools
    import random

    from voiopt.grid import lattice as lattice_mod
    from voiopt.solvers.baselines import heuristics as baselines

    rng = random.Random(5)
    for seed in range(30):
        inst = voiopt.generate(2 + seed % 5, 10, width=3.0 + seed % 3, height=3.0, seed=seed,
                               **({"blocked_fraction": 0.2} if seed % 2 else {}))
        lat = lattice_mod.build(inst)
        cands = {i: np.flatnonzero(lat.in_range[i] & (lat.from_start < lattice_mod.UNREACHABLE)).tolist()
                 for i in range(inst.n_sensors)}
        cands = {i: c for i, c in cands.items() if c}
        steps = {p: lat.steps_from(p) for p in range(lat.n_points)}
        orders = list(itertools.permutations(cands))
        for order in rng.sample(orders, min(6, len(orders))):
            cost = {lat.start: (0.0, [])}
            for i in order:
                cost = {q: min(((c + steps[p][q], [*ps, q]) for p, (c, ps) in cost.items()), key=lambda x: x[0])
                        for q in cands[i]}
            want = min(((c + steps[p][lat.start], ps) for p, (c, ps) in cost.items()), key=lambda x: x[0])
            got = baselines._best_points_for_order(order, cands, baselines._Moves(lat, cands), lat.start)
            assert (got[0], list(got[1])) == (float(want[0]), want[1]), (seed, order)


def test_greedy_and_shortest_path_show_progress(monkeypatch):
    """At 10,000 sensors greedy and shortest-path showed nothing for seconds (issue 47): greedy's
    bar counts slots, shortest-path's the sensors its nearest-neighbour tour has placed."""
    import contextlib

    from voiopt.solvers.baselines import heuristics as baselines

    seen = []

    class Bar:
        def add_task(self, label, **k):
            seen.append((label, k.get("total")))
            return label

        def update(self, task, **k):
            seen.append((task, k.get("completed"), k.get("total")))

    monkeypatch.setattr(baselines, "progress_bar", lambda enabled: contextlib.nullcontext(Bar()))
    monkeypatch.setattr(baselines, "HEURISTIC_TOUR_MAX_SENSORS", 0)  # the nearest-neighbour order, as above 200
    inst = voiopt.generate(9, 12, seed=3)
    voiopt.solve(inst, "greedy", progress=True)
    assert seen[0] == ("greedy slots", 12) and [u[1] for u in seen[1:]] == list(range(1, 13))
    seen.clear()
    voiopt.solve(inst, "shortest-path", progress=True)
    assert seen[0][0] == "shortest-path: the tour" and seen[-1][1:] == (seen[-1][2], seen[-1][2]) and len(seen) > 2
