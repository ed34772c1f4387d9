"""The paper's comparison schemes: the shortest closed walk, and a one-step greedy.

``greedy`` is also the cheap incumbent the exact solvers warm-start from. Both return a plan
that ``Result.from_plan`` simulates; neither reports a value of its own.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import threading
from dataclasses import dataclass

import networkx as nx
import numpy as np

from voiopt import objectives
from voiopt.core import physics
from voiopt.core.instance import Instance
from voiopt.core.plan import Plan
from voiopt.core.result import Result
from voiopt.errors import check_seed
from voiopt.grid import lattice as lattice_mod
from voiopt.objectives import Worth
from voiopt.runtime.progress import progress_bar
from voiopt.runtime.status import Status
from voiopt.runtime.stop import Stop, Stopped, halt_if_asked, watch
from voiopt.solvers import options
from voiopt.solvers.base import (
    DEFAULT_MEMORY_GB,
    check_limits,
    idle_plan,
    lattice_bytes,
    require_memory,
)
from voiopt.solvers.baselines import fleet as fleet_baselines

STEP_BLOCK = 1 << 16  # (sensor, upload) pairs valued between two checks of the stop rule in a greedy step
EXACT_TOUR_MAX_SENSORS = 7  # exact order enumeration up to N! = 5040 orders


def _is_aoi(objective: str) -> bool:
    return objectives.get(objective).worth == Worth.AOI


def _steps_to_sensor(instance: Instance) -> np.ndarray:
    """(N, n) fewest moves from each lattice point into range of each sensor, around blocked
    points (inf if never)."""
    lat = lattice_mod.build(instance)
    # one search per distinct set of in-range points: thousands of sensors share a few hundred
    ranges, which = np.unique(lat.in_range & ~lat.blocked, axis=0, return_inverse=True)
    rows = np.full((len(ranges), lat.n_points), np.inf)
    for j, near in enumerate(ranges):
        if near.any():
            steps = lat.steps_from(np.flatnonzero(near))
            rows[j] = np.where(steps < lattice_mod.UNREACHABLE, steps, np.inf)
    return rows[which.reshape(-1)]


class _Slot:
    """The per-slot arithmetic of greedy: next AoI/distance and a comparable score."""

    def __init__(self, instance: Instance, aoi_objective: bool):
        self.inst = instance
        self.lat = lattice_mod.build(instance)
        self.aoi_objective = aoi_objective
        self.rho = np.array([s.rho for s in instance.sensors])
        self.power = np.array([s.power_w for s in instance.sensors])

    def uploads(self, p: int) -> list[int]:
        """-1 (none) then the sensors in range of point p, ascending."""
        return [-1, *np.flatnonzero(self.lat.in_range[:, p]).tolist()]

    def step(self, aoi: np.ndarray, dist: np.ndarray, p: int,
             stop: Stop | None = None) -> list[tuple[int, np.ndarray, np.ndarray, tuple]]:
        """For each upload u at p: (u, A(t+1), q(t+1), score); higher score is better.

        Score: leximin of the VoI vector (lowest VoI first), or for AoI objectives the leximax
        of the ages negated, so ties on the bottleneck are broken by the next-worst sensor.
        A sensor's VoI depends on its own (age, q) alone, and an upload changes one sensor's:
        so the VoI of each sensor without an upload and of each upload's sensor is computed
        once, and each score is that vector with one entry replaced, sorted. With thousands of
        sensors in range a step still sorts millions of entries, so ``stop`` is checked between
        blocks of about STEP_BLOCK of them (Stopped)."""
        us = self.uploads(p)
        ups = np.asarray(us[1:], dtype=np.int64)
        a_next, dist = np.asarray(aoi, dtype=np.int64) + 1, np.asarray(dist, dtype=float)
        d_up = self.lat.distance[ups, p]
        if self.aoi_objective:  # the ages largest first, negated: the negated ages in ascending order
            base, new = -a_next, np.full(len(ups), -1, dtype=np.int64)
        else:
            base = np.asarray(physics.voi(a_next, dist, self.rho, self.power, self.inst.channel))
            new = np.asarray(physics.voi(np.ones(len(ups)), d_up, self.rho[ups], self.power[ups], self.inst.channel))
        out = []
        rows = max(1, STEP_BLOCK // max(1, len(base)))
        for lo in range(0, len(us), rows):
            halt_if_asked(stop)
            hi = min(lo + rows, len(us))
            block = np.tile(base, (hi - lo, 1))
            for r in range(max(lo, 1), hi):  # row r uploads us[r] = ups[r - 1]
                block[r - lo, ups[r - 1]] = new[r - 1]
            block.sort(axis=1)
            for r, score in zip(range(lo, hi), map(tuple, block), strict=True):
                a1, q1 = a_next.copy(), dist.copy()
                if r:
                    a1[ups[r - 1]], q1[ups[r - 1]] = 1, d_up[r - 1]
                out.append((us[r], a1, q1, score))
        return out

    def voi(self, aoi: np.ndarray, dist: np.ndarray) -> np.ndarray:
        return physics.voi(aoi, dist, self.rho, self.power, self.inst.channel)

    def score(self, aoi: np.ndarray, dist: np.ndarray) -> tuple:
        """The score ``step`` gives one next state (A, q)."""
        if self.aoi_objective:
            return tuple(-np.sort(aoi)[::-1])
        return tuple(np.sort(self.voi(aoi, dist)))

    def bottleneck(self, aoi: np.ndarray, dist: np.ndarray, reachable: np.ndarray) -> int:
        """The worst sensor (lowest VoI, or largest AoI) among those that can ever be served."""
        if self.aoi_objective:
            badness = aoi.astype(float)
        else:
            badness = -np.asarray(physics.voi(aoi, dist, self.rho, self.power, self.inst.channel))
        badness = np.where(reachable, badness, -np.inf)
        return int(np.argmax(badness))


@dataclass(frozen=True)
class GreedyOptions(options.Options):
    """greedy's options: those every method takes."""


@dataclass(frozen=True)
class ShortestPathOptions(options.Options):
    """shortest-path's options (``shortest_path``'s keywords)."""

    seed: int = 0

def greedy(instance: Instance, objective: str, *, progress: bool = False, time_limit: float | None = None,
           memory_limit: float = DEFAULT_MEMORY_GB) -> Result:
    """Each slot, the upload and move that make the next slot best (min VoI, or max AoI).

    Ties are broken in turn by: the best next-but-one slot with the best upload at the new
    position (one-step lookahead); the whole next VoI vector, lowest first (AoI: the ages,
    largest first); fewest moves into range of the then worst sensor; the lookahead's whole
    vector; finally the order none < sensor 0 < ... and stay < N < S < E < W. Deterministic.
    Stopped early (time, memory, Ctrl-C), the entity stays and uploads nothing from then on."""
    objective = objectives.get(objective)
    check_limits(time_limit, memory_limit)
    N, n = instance.n_sensors, lattice_mod.n_points(instance)
    require_memory(lattice_bytes(instance) + 8.0 * N * n + 16.0 * (N + 1) * N, memory_limit, "greedy's tables")
    with watch(time_limit, memory_limit) as stop:
        if instance.fleet:
            slot = _Slot(instance, _is_aoi(objective))
            return fleet_baselines.greedy(instance, objective, stop, slot, _steps_to_sensor(instance))
        with progress_bar(progress) as bar:  # a slot of 10,000 sensors takes seconds: the bar shows the clock
            task = bar.add_task("greedy slots", total=instance.horizon)
            return _greedy(instance, objective, stop, lambda t: bar.update(task, completed=t))


def _greedy(instance: Instance, objective: str, stop: Stop, done=lambda t: None) -> Result:
    aoi_objective = _is_aoi(objective)
    slot = _Slot(instance, aoi_objective)
    lat = slot.lat
    to_sensor = _steps_to_sensor(instance)
    reachable = np.isfinite(to_sensor).any(axis=1)
    aoi = np.array([s.initial_aoi for s in instance.sensors], dtype=np.int64)
    dist = np.array([instance.initial_distance(i) for i in range(instance.n_sensors)])
    p = lat.start
    used = 0  # moves made so far (MODEL.md section 9)
    idx, sched = [], []
    for t in range(instance.horizon):
        best_key, best = None, None
        try:
            for u, a1, q1, score1 in slot.step(aoi, dist, p, stop):
                if stop.check():
                    break
                worst = slot.bottleneck(a1, q1, reachable)
                for m in range(5):
                    p1 = int(lat.neighbors[p, m])
                    if p1 < 0 or t + 1 < instance.horizon and not lat.can_finish(p1, t + 1, used + (p1 != p)):
                        continue  # off the area, blocked, or no way left to end within the budget
                    lookahead = max(s for *_, s in slot.step(a1, q1, p1, stop))
                    steps = to_sensor[worst, p1] if reachable[worst] else 0.0
                    key = (score1[0], lookahead[0], score1, -steps, lookahead)
                    if best_key is None or key > best_key:
                        best_key, best = key, (u, m, a1, q1, p1)
        except Stopped:
            pass  # stop.requested says so
        if stop.requested:
            break
        u, _, aoi, dist, p1 = best
        idx.append(p)
        sched.append(u)
        used += p1 != p
        p = p1
        done(t + 1)
    solver = {"rule": "aoi" if aoi_objective else "voi", "lookahead": 1}
    if stop.requested:
        then = "heading for end without uploads" if lat.end >= 0 else "staying idle"
        solver["stopped"] = f"{stop.describe()} after {len(idx)} of {instance.horizon} slots; then {then}"
        left = instance.horizon - len(idx)
        idx += [p, *lat.walk_home(p, left - 1)] if left else []
        sched += [-1] * left
    return Result.from_plan(
        instance, "greedy", objective, Plan.from_indices(instance, idx, sched), status=stop.reason or Status.FEASIBLE,
        runtime_s=stop.elapsed(), solver=solver,
    )


# ------------------------------------------------------------------------- shortest path


def _lattice_graph(instance: Instance) -> nx.Graph:
    lat = lattice_mod.build(instance)
    g = nx.Graph()
    g.add_nodes_from(range(lat.n_points))
    for p in range(lat.n_points):
        for m in range(1, 5):
            q = int(lat.neighbors[p, m])
            if q >= 0:
                g.add_edge(p, q)
    return g


def _best_points_for_order(order, candidates, dist, start) -> tuple[float, list[int]]:
    """Exact DP: for a fixed sensor order, the in-range point of each sensor minimising the
    closed walk start -> ... -> start. Returns (length, points in order). Each step is one
    array operation over the two sensors' points (``dist.leg``); ties go to the first point in
    candidate order, as a minimum over them in turn would."""
    back, cost, here = [], np.zeros(1), None  # None: the start
    for i in order:
        total = cost[:, None] + dist.leg(here, i)
        arg = total.argmin(axis=0)
        cost = total[arg, np.arange(total.shape[1])]
        back.append(arg)
        here = i
    total = cost + dist.leg(here, None)[:, 0]
    k = int(total.argmin())
    length, pts = float(total[k]), []
    for i, arg in zip(reversed(order), reversed(back), strict=True):
        pts.append(candidates[i][k])
        k = int(arg[k])
    return length, pts[::-1]


class _Moves:
    """dist[p][q]: the fewest moves between lattice points p and q, without a table of all
    pairs: Manhattan on an open lattice, and around blocked points a BFS row per point asked
    (only the start and the sensors' in-range points are). ``leg(a, b)``: the table of them
    from sensor a's in-range points (None: the start) to sensor b's, made once per pair."""

    def __init__(self, lat: lattice_mod.Lattice, candidates: dict[int, list[int]] | None = None) -> None:
        self.lat = lat
        self.rows: dict[int, np.ndarray] = {}
        self.points = {None: [lat.start], **(candidates or {})}
        self.legs: dict[tuple, np.ndarray] = {}

    def __getitem__(self, p: int):
        if self.lat.has_blocked:
            if p not in self.rows:
                self.rows[p] = self.lat.steps_from(p)
            return self.rows[p]
        return _ManhattanRow(self.lat.coords, p)

    def leg(self, a, b) -> np.ndarray:
        if (a, b) not in self.legs:
            src, dst = self.points[a], np.asarray(self.points[b])
            if self.lat.has_blocked:
                table = np.array([self[p][dst] for p in src], dtype=float)
            else:
                c = self.lat.coords
                table = np.abs(c[src][:, None, :] - c[dst][None, :, :]).sum(axis=2).astype(float)
            self.legs[a, b] = table.reshape(len(src), len(dst))
        return self.legs[a, b]


class _ManhattanRow:
    """The fewest moves from point p to any point q of an open lattice."""

    def __init__(self, coords: np.ndarray, p: int) -> None:
        self.coords, self.row = coords, coords[p]

    def __getitem__(self, q: int) -> int:
        return int(abs(self.coords[q, 0] - self.row[0]) + abs(self.coords[q, 1] - self.row[1]))


HEURISTIC_TOUR_MAX_SENSORS = 200  # simulated annealing up to here; nearest neighbour above


def _tour(instance: Instance, stop: Stop, seed: int, sensors: list[int] | None = None,
          placed=lambda k, n: None) -> tuple[list[int], dict]:
    """Waypoints (one in-range point per servable sensor, of ``sensors`` if given) of a shortest
    closed walk from start. Stopped early, the sensors' index order is the tour. ``placed(k, n)``
    hears of the nearest-neighbour order's progress (k of n sensors)."""
    lat = lattice_mod.build(instance)
    start = lat.start
    reach = lat.from_start < lattice_mod.UNREACHABLE  # not walled off by blocked points
    among = range(instance.n_sensors) if sensors is None else sensors
    servable = [i for i in among if (lat.in_range[i] & reach).any()]
    candidates = {i: np.flatnonzero(lat.in_range[i] & reach).tolist() for i in servable}
    dist = _Moves(lat, candidates)
    info = {"unservable_sensors": [i for i in among if i not in servable]}
    if len(servable) <= EXACT_TOUR_MAX_SENSORS:
        best = (math.inf, [])
        for order in itertools.permutations(servable):
            cand = _best_points_for_order(order, candidates, dist, start)
            if cand[0] < best[0]:
                best = cand
            if stop.check():
                break
        info["tour"] = "exact" if not stop.requested else "best order found before the stop"
    else:
        order = None
        if len(servable) <= HEURISTIC_TOUR_MAX_SENSORS:
            order = _annealed_order(servable, candidates, dist, start, stop, seed)
            info["tour"] = "heuristic: networkx simulated_annealing_tsp order + exact point choice"
        if order is None:  # many sensors, or stopped: the nearest sensor next
            order = _nearest_order(servable, candidates, dist, start, stop, placed)
            info["tour"] = "heuristic: nearest neighbour order + exact point choice"
        best = _best_points_for_order(order, candidates, dist, start)
    info["tour_length"] = int(best[0]) if math.isfinite(best[0]) else 0
    return best[1], info


def _nearest_order(servable, candidates, dist, start, stop: Stop, placed=lambda k, n: None) -> list[int]:
    """From the start, the sensor nearest to the last one's points next (index order once stopped)."""
    order, left, here = [], set(servable), [start]
    while left and not stop.check():
        nxt = min(left, key=lambda i: (min(dist[x][y] for x in here for y in candidates[i]), i))
        placed(len(order) + 1, len(servable))
        order.append(nxt)
        left.discard(nxt)
        here = candidates[nxt]
    return order + sorted(left)


def _annealed_order(servable, candidates, dist, start, stop: Stop, seed: int) -> list[int] | None:
    """An order from networkx's TSP (simulated annealing, fixed seed) over the sensors with the
    fewest moves between their in-range sets; None if the stop rule ends it first."""
    h = nx.complete_graph(["start", *servable])

    def gap(a, b):
        qa = [start] if a == "start" else candidates[a]
        qb = [start] if b == "start" else candidates[b]
        return min(dist[x][y] for x in qa for y in qb)

    for a, b in h.edges:
        if stop.check():
            return None
        h[a][b]["weight"] = gap(a, b)
    box: list = []
    worker = threading.Thread(target=lambda: box.append(
        nx.approximation.simulated_annealing_tsp(h, "greedy", weight="weight", seed=seed)), daemon=True)
    worker.start()
    while worker.is_alive():  # the annealing cannot be interrupted: it is left behind if need be
        worker.join(0.05)
        if stop.check():
            return None
    cycle = box[0]
    k = cycle.index("start")
    return [v for v in cycle[k + 1:] + cycle[1:k] if v != "start"]


def shortest_path(instance: Instance, objective: str, *, progress: bool = False, seed: int = 0,
                  time_limit: float | None = None, memory_limit: float = DEFAULT_MEMORY_GB) -> Result:
    """The paper's benchmark: the shortest closed walk from start that comes within d_th of
    every sensor, followed cyclically for T slots, uploading the in-range sensor of largest
    AoI each slot (lowest index on ties). Around blocked points the walk takes BFS distances;
    with an end or a budget it leaves the cycle for the fewest moves to end when going on
    would leave no way there (MODEL.md section 9). Exact tour for N <= 7, a heuristic above; stopped
    early (time, memory, Ctrl-C), the best tour found so far."""
    objective = objectives.get(objective)
    check_seed(seed)
    check_limits(time_limit, memory_limit)
    n = lattice_mod.n_points(instance)
    require_memory(lattice_bytes(instance) + 1000.0 * n, memory_limit, "shortest-path's lattice graph and tables")
    with watch(time_limit, memory_limit) as stop:
        if instance.fleet:
            def tour(robot: Instance, sensors: list[int]):
                waypoints, info = _tour(robot, stop, int(seed), sensors)
                return closed_walk(robot, waypoints), info
            return fleet_baselines.shortest_path(instance, objective, stop, int(seed), tour)
        with progress_bar(progress) as bar:  # 10,000 sensors: the tour's order takes a while
            task = bar.add_task("shortest-path: the tour", total=None)
            return _shortest_path(instance, objective, stop, int(seed),
                                  lambda k, n: bar.update(task, completed=k, total=n))


def closed_walk(instance: Instance, waypoints: list[int]) -> list[int]:
    """The lattice points of the closed walk start -> waypoints -> start, along shortest paths,
    without the final return to start (it is the cycle's first point)."""
    lat = lattice_mod.build(instance)
    g = _lattice_graph(instance)
    walk = [lat.start]
    for q in [*waypoints, lat.start]:
        walk.extend(nx.shortest_path(g, walk[-1], q)[1:])
    return walk[:-1] if len(walk) > 1 else walk


def _largest_aoi_uploads(instance: Instance, lat, positions: list[int]) -> list[int]:
    """Each slot's upload: the sensor in range of the robot's point with the largest AoI, the
    lowest index on ties (-1: none in range). The AoI of sensor i in slot t is t + off[i]
    (MODEL.md section 3: every age grows by one, an upload's sensor is 1 in the next slot), so
    the ages are never stored; plain ints, as T may be 10^6."""
    in_range = [np.flatnonzero(lat.in_range[:, p]).tolist() for p in range(lat.n_points)]
    off = [s.initial_aoi for s in instance.sensors]
    sched = []
    for t, p in enumerate(positions):
        u = max(in_range[p], key=lambda i: (off[i], -i), default=-1)
        if u >= 0:
            off[u] = -t
        sched.append(u)
    return sched


def _shortest_path(instance: Instance, objective: str, stop: Stop, seed: int, placed=lambda k, n: None) -> Result:
    lat = lattice_mod.build(instance)
    waypoints, info = _tour(instance, stop, seed, placed=placed)
    cycle = closed_walk(instance, waypoints)
    positions = [lat.start]
    used, home = 0, False
    T, to_end, budget = instance.horizon, lat.to_end.tolist(), int(lat.budget)  # plain ints: T may be 10^6
    for t in range(1, T):  # the cycle while it leaves a way to end in time and budget (lat.can_finish)
        p, q = positions[-1], cycle[t % len(cycle)]
        moves = used + (q != p)
        home = home or not (to_end[q] <= min(T - 1 - t, budget - moves) and moves <= budget)
        if home:
            q = lat.walk_home(p, 1)[0]
        used += q != p
        positions.append(q)
    if home:
        info["heads_home_from_slot"] = next(t for t in range(T) if positions[t] != cycle[t % len(cycle)])
    plan = Plan.from_indices(instance, positions, _largest_aoi_uploads(instance, lat, positions))
    if stop.requested:
        info["stopped"] = stop.describe()
    return Result.from_plan(
        instance, "shortest-path", objective, plan, status=stop.reason or Status.FEASIBLE,
        runtime_s=stop.elapsed(), solver={**info, "seed": int(seed)},
    )


def stopped_result(instance: Instance, method: str, objective: str, stop, solver: dict, where: str) -> Result:
    """The result of a solve stopped (``stop``, voiopt.runtime.stop.Stop) before it had a plan, ``where``
    saying where: one robot's idle plan; a fleet's, greedy's plan stopped at once (its walker
    keeps the rules between robots), greedy's result relabelled so that the plan is valued
    once; where greedy has none, its status and why."""
    solver = {**solver, "stopped": stop.describe()}
    if not instance.fleet:
        return Result.from_plan(instance, method, objective, idle_plan(instance), status=stop.reason,
                                runtime_s=stop.elapsed(),
                                solver={**solver, "note": f"{where}; the plan heads for the end (or stays) without uploads"})
    walked = greedy(instance, objective, time_limit=1e-9, memory_limit=stop.memory_limit)
    if walked.plan is None:  # greedy's walker proved there is no plan, or gave up
        return Result.from_plan(instance, method, objective, None, status=walked.status, runtime_s=stop.elapsed(),
                                solver={**solver, "note": f"{where}; greedy found no plan: {walked.solver['note']}"})
    return dataclasses.replace(walked, method=method, status=stop.reason, runtime_s=stop.elapsed(),
                               solver={**solver, "note": f"{where}; the plan is greedy's, stopped at once"})
