"""The paper's comparison schemes for several robots (MODEL.md section 10).

``shortest_path`` splits the sensors among the robots (balanced clusters), gives each robot
the one-robot shortest closed walk over its cluster, and uploads by largest AoI, jointly.
``greedy`` chooses the joint upload that makes the next slot best, then moves each robot
towards its own bottleneck sensor with the one-robot lookahead.

Both execute slot by slot through one conflict-free walker, ``_walk``: a depth-first search over
the robots' next points in each one's order of preference, which skips shared points, swaps
and points from which a robot's own end (section 9) is out of reach, and backtracks when a
slot has no legal joint move. Neither reports a value of its own.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Iterator

import numpy as np

from voiopt.core.instance import Instance
from voiopt.core.plan import Plan
from voiopt.core.result import Result
from voiopt.core.simulate import advance
from voiopt.grid import lattice as lattice_mod
from voiopt.grid.joint import NoJointPlan
from voiopt.runtime.status import Status
from voiopt.runtime.stop import Stop

MAX_JOINT_UPLOADS = 4096  # joint upload choices scored exhaustively per slot; above, robot by robot
MAX_TRIES = 20_000  # joint moves the walker may try beyond one per slot before it gives up (about 15 s for greedy)
MAX_TRIES_STOPPED = 500  # and once the stop rule has fired (then robots only head home)
GRACE_S = 0.5  # nor may a stopped walk run on for longer once every robot could be home: a doomed one
# wastes no tries, one slot at a time, to T (a walk still on its robots' fewest moves home may go on)
MAX_NODES = 20_000  # partial joint moves one slot's enumeration may visit (on a packed lattice it is exponential)


def _assignment(cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """scipy's linear_sum_assignment, imported on first use: scipy.optimize is 0.2 to 0.3 s of
    start-up, which one-robot commands (dp's and greedy's, through baselines) never need."""
    from scipy.optimize import linear_sum_assignment

    return linear_sum_assignment(cost)


def _lattices(instance: Instance) -> list[lattice_mod.Lattice]:
    return [lattice_mod.build(instance.robot(k)) for k in range(instance.n_robots)]


class _Cut(Exception):
    """An enumeration of joint moves cut short (MAX_NODES, or the stop rule)."""


def _joint_options(lats, cur: tuple[int, ...], used: tuple[int, ...], t: int,
                   prefer: Callable[[int, list[int]], list[int]], stop: Stop, cuts: list[int]) -> Iterator[tuple[int, ...]]:
    """The joint next points for slot t + 1 in lexicographic order of the robots' preferences
    (robot 0's first), legal by MODEL.md sections 9 and 10.

    On a lattice packed with robots almost every partial choice is a dead end found only
    robots later, and the search is exponential: 36 robots on 6 x 6 points did not finish one
    slot in 11 minutes. So after MAX_NODES partial choices, or once the stop rule fires, it
    ends with every robot staying where it is (never a shared point or a swap), if each may
    stay and still finish. Each cut appends t to ``cuts``: a walk that then runs out of joint
    moves has proven nothing."""
    K = len(cur)
    choices = []
    for k, lat in enumerate(lats):
        moves = sorted({int(q) for q in lat.neighbors[cur[k]] if q >= 0})
        ok = [q for q in moves if lat.can_finish(q, t + 1, used[k] + (q != cur[k]))]
        choices.append(prefer(k, ok))
    nodes = 0

    def rec(k: int, chosen: tuple[int, ...]):
        nonlocal nodes
        if k == K:
            yield chosen
            return
        for q in choices[k]:
            nodes += 1
            if nodes > MAX_NODES or (nodes % 1024 == 0 and stop.check()):
                raise _Cut
            if any(q == chosen[j] or (q == cur[j] and chosen[j] == cur[k]) for j in range(k)):
                continue  # a shared point, or a swap with robot j
            yield from rec(k + 1, (*chosen, q))

    def options():
        try:
            yield from rec(0, ())
        except _Cut:
            cuts.append(t)
            if all(cur[k] in choices[k] for k in range(K)):
                yield tuple(cur)

    return options()


def _walk(instance: Instance, stop: Stop, state0, begin: Callable, prefer: Callable, on_move: Callable):
    """Positions and schedule (K, T) of a conflict-free joint plan.

    ``begin(t, cur, state) -> (uploads, state')``: the uploads of slot t at points ``cur``
    (distinct sensors, -1 none) and the state after them; ``prefer(t, cur, state) -> f(k, ok)``
    orders robot k's legal next points; ``on_move(state, cur, nxt) -> state``. ``state`` is
    the heuristic's own (ages, distances, walk pointers; ``state0`` in slot 0), kept per slot
    so that backtracking restores it. Once the stop rule fires, robots head for their ends
    without uploads, and stay there to the last slot (filled in at once: T may be 10^6)."""
    lats = _lattices(instance)
    K, T = instance.n_robots, instance.horizon
    cur0 = tuple(lat.start for lat in lats)
    frames = []  # per slot t: (cur, used, uploads, state after uploads, options)
    tries, stopped_at, stopped_clock, home_by, cuts = 0, None, 0.0, 0, []

    def open_frame(t, cur, used, state):
        if stop.check():
            uploads, after = (-1,) * K, state
            order = _homeward(lats)
        else:
            uploads, after = begin(t, cur, state)
            order = prefer(t, cur, after)
        opts = _joint_options(lats, cur, used, t, order, stop, cuts) if t + 1 < T else iter([None])
        frames.append((cur, used, tuple(uploads), after, opts))

    open_frame(0, cur0, (0,) * K, state0)
    home = 0  # slots after the last frame in which every robot stays, without uploads
    while frames:
        t = len(frames) - 1
        cur, used, uploads, state, opts = frames[-1]
        if stop.requested and all(lat.to_end[c] == 0 for lat, c in zip(lats, cur, strict=True)):
            home = T - 1 - t  # stopped, and every robot at its end (or with none): staying is legal to the last slot
            break
        nxt = next(opts, False)
        if nxt is False:
            frames.pop()  # no legal joint move left from here: back to the slot before
            continue
        if nxt is None:
            break  # the last slot: done
        tries += 1
        if stop.requested and stopped_at is None:
            stopped_at = tries - t  # a plan needs one joint move per slot: budgets count the tries beyond
            stopped_clock = time.monotonic()
            home_by = t + max(int(lat.to_end[c]) for lat, c in zip(lats, cur, strict=True))
        if tries - t > MAX_TRIES or stopped_at is not None and (tries - t - stopped_at > MAX_TRIES_STOPPED or (
                t > home_by and time.monotonic() - stopped_clock > GRACE_S)):
            raise NoJointPlan(f"the conflict-free walker gave up after {tries - 1} joint moves (slot {t}"
                              f"{', stopped' if stopped_at is not None else ''})", False)
        new_used = tuple(u + (a != b) for u, a, b in zip(used, cur, nxt, strict=True))
        open_frame(t + 1, nxt, new_used, on_move(state, cur, nxt))
    if not frames:  # every joint move tried: a proof, unless some slot's enumeration was cut short
        raise NoJointPlan("no conflict-free joint plan exists for these robots' starts, ends and budgets"
                          if not cuts else f"the conflict-free walker ran out of joint moves, some cut short (slot {cuts[0]})",
                          not cuts)
    idx = np.array([f[0] for f in frames] + [frames[-1][0]] * home, dtype=np.int64).T
    sched = np.array([f[2] for f in frames] + [(-1,) * K] * home, dtype=np.int64).T
    return idx, sched


def _homeward(lats):
    """Preference once stopped: fewest moves to end first (a robot with an end never ties a
    move with staying; one without goes on moving, which frees another robot's end: preferring
    to stay there left stopped walks with no plan, a review found)."""
    def order(k, ok):
        return sorted(ok, key=lambda q: (lats[k].to_end[q], q))
    return order


def _result(instance, method, objective, stop, solver, state0, begin, prefer, on_move) -> Result:
    """The walker's plan; if it gave up (a trap: some robot's way home blocked by another's
    choices, found only after long backtracking), two robots' legal joint paths from dp's pass
    without uploads (exact: it also proves there are none), with the heuristic's own uploads
    along them."""
    try:
        idx, sched = _walk(instance, stop, state0, begin, prefer, on_move)
    except NoJointPlan as e:
        proof, paths = (e if e.proved else None), None
        staying = _staying(instance)
        if proof is None and stop.requested and staying is not None:
            paths = staying  # stopped: no time for the exact search, and staying put is legal
        elif proof is None:
            try:
                paths = _legal_paths(instance, objective, stop)
            except NoJointPlan as none:
                proof = none
            paths = staying if paths is None and proof is None else paths
        if proof is not None:
            return Result.from_plan(instance, method, objective, None, status=Status.INFEASIBLE, runtime_s=stop.elapsed(),
                                    solver={**solver, "note": str(proof)})
        if paths is None:
            return Result.from_plan(instance, method, objective, None, status=Status.ERROR, runtime_s=stop.elapsed(),
                                    solver={**solver, "note": f"{e}; a legal plan may still exist (milp may find one)"})
        if stop.requested:  # robots head home without uploads once stopped; here they are home
            idx, sched = paths, np.full_like(paths, -1)
        else:
            idx, sched = paths, _uploads_along(paths, state0, begin, on_move)
        how = "every robot staying at its start" if paths is staying else "exactly found legal joint paths"
        solver["walker"] = f"{e}; {'no uploads' if stop.requested else 'uploads chosen'} along {how} instead"
    if stop.requested:
        solver["stopped"] = f"{stop.describe()}; the robots then head for their ends without uploads"
    return Result.from_plan(instance, method, objective, Plan.from_indices(instance, idx, sched),
                            status=stop.reason or Status.FEASIBLE, runtime_s=stop.elapsed(), solver=solver)


def _staying(instance: Instance) -> np.ndarray | None:
    """(K, T) positions of every robot staying at its start, if that is legal: each start is
    its robot's end, or it has none (staying makes no moves, and starts are distinct). A
    stopped walk whose robots block each other's way home falls back on it (a fuzz campaign
    found such walks giving up with no plan on factory floors, where the robots start at the
    dock)."""
    lats = _lattices(instance)
    if any(lat.to_end[lat.start] != 0 for lat in lats):
        return None
    return np.repeat(np.array([[lat.start] for lat in lats], dtype=np.int64), instance.horizon, axis=1)


def _legal_paths(instance: Instance, objective: str, stop: Stop) -> np.ndarray | None:
    """(K, T) legal joint paths, found exactly (NoJointPlan, proved, if there are none): for
    two robots by fleet_dp's pass without uploads, else (or where dp declines) by a walk
    through the joint table of states that can still finish (fleet_mdp.legal_paths, small
    lattices only); None where neither applies."""
    from voiopt.errors import VoioptError
    from voiopt.mdp import fleet as fleet_mdp
    from voiopt.solvers.labels import fleet_search

    if instance.n_robots == 2:
        try:
            fleet_search.check_fleet(instance, stop.memory_limit)
            out = fleet_search.legal_pass(fleet_search.build_joint(instance, objective), stop)
        except VoioptError:
            out = None
        if out is not None and out.plan is None:
            raise NoJointPlan("no legal joint plan exists (dp's pass without uploads proved it)", True)
        if out is not None:
            return np.asarray(out.plan[0], dtype=np.int64)
    return fleet_mdp.legal_paths(instance)


def _uploads_along(idx: np.ndarray, state, begin, on_move) -> np.ndarray:
    """The heuristic's uploads, slot by slot, along fixed joint paths (K, T)."""
    sched = np.empty_like(idx)
    for t in range(idx.shape[1]):
        cur = tuple(int(p) for p in idx[:, t])
        uploads, state = begin(t, cur, state)
        sched[:, t] = uploads
        if t + 1 < idx.shape[1]:
            state = on_move(state, cur, tuple(int(p) for p in idx[:, t + 1]))
    return sched


# ------------------------------------------------------------------------- shortest path


def clusters(instance: Instance, sensors: list[int], iterations: int = 20) -> list[list[int]]:
    """Balanced clusters of the sensors, one per robot: k-means on the sensor positions with
    every cluster holding at most ceil(N / K) sensors (an assignment problem each round),
    seeded by farthest points; the clusters then go to the robots that reach them in the
    fewest moves in total. Deterministic."""
    K = instance.n_robots
    if not sensors:
        return [[] for _ in range(K)]
    pos = np.array([instance.sensors[i].position for i in sensors], dtype=float)
    k_eff = min(K, len(sensors))
    centres = [pos[0]]
    while len(centres) < k_eff:
        d = np.min([np.hypot(*(pos - c).T) for c in centres], axis=0)
        centres.append(pos[int(np.argmax(d))])
    centres = np.array(centres)
    cap = math.ceil(len(sensors) / k_eff)
    label = np.zeros(len(sensors), dtype=np.int64)
    for _ in range(iterations):
        cost = np.hypot(pos[:, None, 0] - centres[None, :, 0], pos[:, None, 1] - centres[None, :, 1])
        rows, cols = _assignment(np.repeat(cost, cap, axis=1))
        new = np.empty(len(sensors), dtype=np.int64)
        new[rows] = cols // cap
        if _ and (new == label).all():
            break
        label = new
        centres = np.array([pos[label == c].mean(axis=0) for c in range(k_eff)])
    lats = _lattices(instance)
    groups = [[sensors[j] for j in np.flatnonzero(label == c)] for c in range(k_eff)] + [[]] * (K - k_eff)
    cost = np.array([[min((int(lat.from_start[lat.in_range[i]].min()) for i in g), default=0) for g in groups]
                     for lat in lats], dtype=float)
    rows, cols = _assignment(cost)
    return [groups[c] for c in cols[np.argsort(rows)]]


def shortest_path(instance: Instance, objective: str, stop: Stop, seed: int, tour: Callable) -> Result:
    """The fleet form of baselines.shortest_path (see the module's docstring); ``tour(instance,
    sensors)`` is the one-robot closed walk (lattice points) over ``sensors``, and its info."""
    lats = _lattices(instance)
    servable = [i for i in range(instance.n_sensors)
                if any((lat.in_range[i] & (lat.from_start < lattice_mod.UNREACHABLE)).any() for lat in lats)]
    groups = clusters(instance, servable)
    cycles, info = [], {"clusters": groups, "unservable_sensors": [i for i in range(instance.n_sensors)
                                                                   if i not in servable]}
    for k, lat in enumerate(lats):
        mine = [i for i in groups[k] if (lat.in_range[i] & (lat.from_start < lattice_mod.UNREACHABLE)).any()]
        cycle, about = tour(instance.robot(k), mine)
        cycles.append(cycle)
        info[f"robot_{k}_tour_length"] = about["tour_length"]
    steps_to = {}

    def towards(q: int) -> np.ndarray:
        if q not in steps_to:
            steps_to[q] = lats[0].steps_from(q)
        return steps_to[q]

    def begin(t, cur, state):
        aoi, pointers = state
        uploads, taken = [], set()
        for p in cur:  # robot by robot: the in-range sensor of largest AoI not taken this slot
            near = [i for i in np.flatnonzero(lats[0].in_range[:, p]).tolist() if i not in taken]
            u = max(near, key=lambda i: (aoi[i], -i)) if near else -1
            uploads.append(u)
            taken.add(u)
        aoi, _ = advance(aoi, aoi, uploads, [1] * len(uploads))  # ages only
        return uploads, (aoi, pointers)

    def prefer(t, cur, state):
        _, pointers = state

        def order(k, ok):
            want = cycles[k][(pointers[k] + 1) % len(cycles[k])]
            return sorted(ok, key=lambda q: (q != want, towards(want)[q], q != cur[k], q))
        return order

    def on_move(state, cur, nxt):
        aoi, pointers = state
        return aoi, tuple(p + 1 if nxt[k] == cycles[k][(p + 1) % len(cycles[k])] else p
                          for k, p in enumerate(pointers))

    state0 = (np.array([s.initial_aoi for s in instance.sensors], dtype=np.int64), (0,) * instance.n_robots)
    return _result(instance, "shortest-path", objective, stop, {**info, "seed": int(seed)}, state0, begin, prefer,
                   on_move)


# ------------------------------------------------------------------------- greedy


def greedy(instance: Instance, objective: str, stop: Stop, slot, to_sensor: np.ndarray) -> Result:
    """The fleet form of baselines.greedy (see the module's docstring): ``slot`` is its per-slot
    arithmetic (baselines._Slot), ``to_sensor`` the fewest moves into each sensor's range."""
    aoi_objective = slot.aoi_objective
    lat = slot.lat
    reachable = np.isfinite(to_sensor).any(axis=1)

    def begin(t, cur, state):
        aoi, dist = state
        options = [slot.uploads(p) for p in cur]
        best = None
        if math.prod(map(len, options)) <= MAX_JOINT_UPLOADS:
            joint = itertools.product(*options)
        else:  # robot by robot, each the best given those before it
            joint = [_sequential(options, cur, aoi, dist, lat, slot.score)]
        for us in joint:
            if len({u for u in us if u >= 0}) < sum(u >= 0 for u in us):
                continue  # a sensor uploads to at most one robot per slot
            a, q = _advance_all(aoi, dist, us, cur, lat)
            key = slot.score(a, q)
            if best is None or key > best[0]:
                best = (key, us, a, q)
        return best[1], (best[2], best[3])

    def prefer(t, cur, state):
        aoi, dist = state
        worst = _bottlenecks(slot, aoi, dist, reachable, len(cur))
        targets = _assign_targets(worst, cur, to_sensor)

        def order(k, ok):
            keys = {}
            for q in ok:
                look = max(s for *_, s in slot.step(aoi, dist, q))
                steps = to_sensor[targets[k], q] if targets[k] >= 0 else 0.0
                keys[q] = (look[0], -steps, look, q == cur[k], -q)
            return sorted(ok, key=lambda q: keys[q], reverse=True)
        return order

    def on_move(state, cur, nxt):
        return state

    solver = {"rule": "aoi" if aoi_objective else "voi", "lookahead": 1, "uploads": "joint"}
    state0 = (np.array([s.initial_aoi for s in instance.sensors], dtype=np.int64),
              np.array([instance.initial_distance(i) for i in range(instance.n_sensors)]))
    return _result(instance, "greedy", objective, stop, solver, state0, begin, prefer, on_move)


def _advance_all(aoi, dist, uploads, cur, lat):
    return advance(aoi, dist, uploads, lat.distance[list(uploads), list(cur)])


def _sequential(options, cur, aoi, dist, lat, score) -> tuple[int, ...]:
    chosen: list[int] = []
    for k, opts in enumerate(options):
        best = None
        for u in opts:
            if u >= 0 and u in chosen:
                continue
            us = (*chosen, u, *([-1] * (len(options) - k - 1)))
            key = score(*_advance_all(aoi, dist, us, cur, lat))
            if best is None or key > best[0]:
                best = (key, u)
        chosen.append(best[1])
    return tuple(chosen)


def _bottlenecks(slot, aoi, dist, reachable, K) -> list[int]:
    """The K worst servable sensors (lowest VoI or largest AoI), worst first."""
    badness = aoi.astype(float) if slot.aoi_objective else -np.asarray(slot.voi(aoi, dist))
    order = np.lexsort((np.arange(len(badness)), -np.where(reachable, badness, -np.inf)))
    return [int(i) for i in order[:K] if reachable[i]]


def _assign_targets(worst: list[int], cur, to_sensor) -> list[int]:
    """Each robot's target among the worst sensors: fewest moves in total (-1: none left)."""
    K = len(cur)
    if not worst:
        return [-1] * K
    cost = np.array([[to_sensor[i, p] for i in worst] for p in cur])
    rows, cols = _assignment(np.where(np.isfinite(cost), cost, 1e9))
    out = [-1] * K
    for r, c in zip(rows, cols, strict=True):
        out[r] = worst[c]
    return out
