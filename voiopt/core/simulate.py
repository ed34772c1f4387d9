"""The dynamics of MODEL.md section 3: a plan becomes per-slot AoI, distance, VoI and metrics.

This module is the single source of every number voiopt reports. Solvers return plans;
only ``simulate`` turns them into values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from voiopt.core import physics
from voiopt.core.instance import Instance
from voiopt.core.plan import FleetPlan, Plan
from voiopt.errors import PlanError
from voiopt.grid import lattice as lattice_mod
from voiopt.grid.places import in_area
from voiopt.objectives import metrics_of


@dataclass(frozen=True)
class Trajectory:
    """Per-slot state, index t = 0..T (row 0 is the initial state, rows 1..T are scored)."""

    positions: np.ndarray  # (T, ) lattice point index of p(t), t = 0..T-1; (K, T) for a fleet
    schedule: np.ndarray  # (T, ) sensor index or -1; (K, T) for a fleet
    aoi: np.ndarray  # (T+1, N) A_i(t)
    distance: np.ndarray  # (T+1, N) q_i(t)
    voi: np.ndarray  # (T+1, N) V_i(t), bit/s
    metrics: dict[str, float]


def check_plan(instance: Instance, plan: Plan | FleetPlan) -> tuple[np.ndarray, np.ndarray]:
    """Validate a plan against MODEL.md sections 3, 9 and 10; return (point indices, schedule
    with -1): (T,) arrays for one robot, (K, T) for a fleet."""
    if instance.fleet or len(plan.robots) > 1:
        return _check_fleet(instance, plan)
    if isinstance(plan, FleetPlan):
        plan = plan.robots[0]
    lat = lattice_mod.build(instance)
    T, N = instance.horizon, instance.n_sensors
    if len(plan.positions) != T:
        raise PlanError(f"positions: must have horizon = {T} entries, got {len(plan.positions)}")
    if len(plan.schedule) != T:
        raise PlanError(f"schedule: must have horizon = {T} entries, got {len(plan.schedule)}")
    idx = _indices(lat, plan.positions)
    if idx is None:
        idx = _indices_slot_by_slot(instance, lat, plan.positions)
    if idx[0] != lat.start:
        x, y = plan.positions[0]
        raise PlanError(f"positions[0]: must equal start {list(instance.start)}, got [{x:g}, {y:g}]")
    steps = (lat.neighbors[idx[:-1]] == idx[1:, None]).any(axis=1)  # positions[t] one step (or stay) from t - 1
    if not steps.all():
        t = int(np.argmin(steps)) + 1
        (x0, y0), (x1, y1) = plan.positions[t - 1], plan.positions[t]
        raise PlanError(
            f"positions[{t}]: [{x1:g}, {y1:g}] is not one N/S/E/W step (or stay) from positions[{t-1}] [{x0:g}, {y0:g}]"
        )
    _check_field_rules(instance, plan, idx)
    sched = _schedule(lat, plan.schedule, idx, N)
    if sched is None:
        sched = _schedule_slot_by_slot(instance, lat, plan.schedule, idx)
    return idx, sched


def _indices(lat, positions) -> np.ndarray | None:
    """The lattice point of each position, or None if some position is not an open lattice
    point. A long plan stands on few points: each distinct one is looked up once, and the
    slots are mapped at C speed (T = 10^6: 0.9 s as a loop over the slots)."""
    known: dict[tuple, int] = {}
    try:
        for xy in set(positions):
            p = lat.index(*xy)
            if p is None or lat.blocked[p]:
                return None
            known[xy] = p
    except (TypeError, ValueError, OverflowError):  # not a pair of numbers (a plan built in Python, not
        return None  # read from JSON): slot by slot, for the first bad slot's own message
    return np.fromiter(map(known.__getitem__, positions), np.int64, len(positions))


def _indices_slot_by_slot(instance: Instance, lat, positions) -> np.ndarray:
    """The lattice point of each position, slot by slot: raises the PlanError of the first
    position that is not an open lattice point."""
    idx = np.empty(len(positions), dtype=np.int64)
    for t, (x, y) in enumerate(positions):
        p = lat.index(x, y)
        if p is None:
            why = "is not a lattice point" if in_area(x, y, instance.width, instance.height) else "is outside the area"
            raise PlanError(f"positions[{t}]: [{x:g}, {y:g}] {why} (step {instance.step:g}, area {instance.width:g} x {instance.height:g})")
        if lat.blocked[p]:
            raise PlanError(f"positions[{t}]: [{x:g}, {y:g}] is a blocked point (blocked points may never be stood on)")
        idx[t] = p
    return idx


def _schedule(lat, schedule, idx: np.ndarray, N: int) -> np.ndarray | None:
    """The schedule with -1 for none, or None if some entry is not a sensor in range (then
    ``_schedule_slot_by_slot`` names the first): checked on all slots at once."""
    if not set(map(type, schedule)) <= {int, type(None)}:
        return None
    try:
        sched = np.fromiter((-1 if u is None else u for u in schedule), np.int64, len(schedule))
    except OverflowError:  # an int beyond 64 bits
        return None
    up = sched >= 0
    if (sched < -1).any() or (sched >= N).any() or int((~up).sum()) != schedule.count(None):
        return None  # an index out of range, or a -1 given as a sensor
    return sched if lat.in_range[sched[up], idx[up]].all() else None


def _schedule_slot_by_slot(instance: Instance, lat, schedule, idx: np.ndarray) -> np.ndarray:
    """The schedule with -1 for none, checked slot by slot: raises the PlanError of the first
    entry that is not a sensor in range (also any entry that is not an int or None)."""
    N = instance.n_sensors
    sched = np.full(len(schedule), -1, dtype=np.int64)
    for t, u in enumerate(schedule):
        if u is None:
            continue
        if isinstance(u, bool) or not isinstance(u, (int, np.integer)):
            raise PlanError(f"schedule[{t}]: must be a sensor index or null, got {u!r} (one sensor per slot)")
        if not 0 <= u < N:
            raise PlanError(f"schedule[{t}]: unknown sensor index {u} (the instance has {N} sensors)")
        if not lat.in_range[u, idx[t]]:
            d, d_th = float(lat.distance[u, idx[t]]), instance.channel.d_th
            shown, limit = f"{d:.4g}", f"{d_th:g}"
            if float(shown) <= float(limit):  # rounding would hide the excess: "distance 1 > d_th 1"
                shown, limit = repr(d), repr(d_th)
            raise PlanError(f"schedule[{t}]: sensor {u} is out of range at positions[{t}] (distance {shown} > d_th {limit})")
        sched[t] = u
    return sched


def _check_fleet(instance: Instance, plan: Plan | FleetPlan) -> tuple[np.ndarray, np.ndarray]:
    """Each robot's plan on its own (section 9, messages prefixed robots[k].), then the rules
    between robots of section 10: no shared point, no swap, no sensor uploading twice."""
    K, T = instance.n_robots, instance.horizon
    if len(plan.robots) != K:
        raise PlanError(f"robots: the instance has {K} robots, so a plan needs one entry per robot "
                        f"({{\"robots\": [{{positions, schedule}}, ...]}}), got {len(plan.robots)}")
    idx = np.empty((K, T), dtype=np.int64)
    sched = np.empty((K, T), dtype=np.int64)
    for k in range(K):
        try:
            idx[k], sched[k] = check_plan(instance.robot(k), plan.robots[k])
        except PlanError as e:
            raise PlanError(f"robots[{k}].{e}") from None
    if not _conflicts(idx, sched):
        return idx, sched
    pts = lattice_mod.build(instance).points
    xy = lambda p: f"[{pts[p, 0]:g}, {pts[p, 1]:g}]"  # noqa: E731
    for t in range(T):  # the first conflict, slot by slot, for its message
        for k in range(1, K):
            for j in range(k):
                if idx[k, t] == idx[j, t]:
                    raise PlanError(f"robots[{k}].positions[{t}]: {xy(idx[k, t])} is also robot {j}'s point in slot "
                                    f"{t} (two robots never share a lattice point)")
                if t and idx[k, t] == idx[j, t - 1] and idx[j, t] == idx[k, t - 1]:
                    raise PlanError(f"robots[{k}].positions[{t}]: robots {j} and {k} swap points {xy(idx[j, t])} and "
                                    f"{xy(idx[k, t])} between slots {t - 1} and {t} (robots never swap points)")
                if sched[k, t] >= 0 and sched[k, t] == sched[j, t]:
                    raise PlanError(f"robots[{k}].schedule[{t}]: sensor {sched[k, t]} also uploads to robot {j} in slot "
                                    f"{t} (a sensor uploads to at most one robot per slot)")
    return idx, sched


def _conflicts(idx: np.ndarray, sched: np.ndarray) -> bool:
    """Whether two robots share a point, swap points or upload one sensor in some slot: the
    rules between robots of section 10, on all slots at once (a loop over the slots took
    most of a second at T = 10^5)."""
    for k in range(1, len(idx)):
        for j in range(k):
            if (idx[k] == idx[j]).any() or ((sched[k] >= 0) & (sched[k] == sched[j])).any():
                return True
            if ((idx[k, 1:] == idx[j, :-1]) & (idx[j, 1:] == idx[k, :-1])).any():
                return True
    return False


def _check_field_rules(instance: Instance, plan: Plan, idx: np.ndarray) -> None:
    """``end`` and ``max_moves`` of MODEL.md section 9 (blocked points are checked per slot)."""
    T = instance.horizon
    if instance.end is not None and idx[T - 1] != lattice_mod.build(instance).end:
        x, y = plan.positions[T - 1]
        ex, ey = instance.end
        raise PlanError(f"positions[{T - 1}]: must equal end [{ex:g}, {ey:g}] in the last slot, got [{x:g}, {y:g}]")
    if instance.max_moves is not None:
        moved = np.flatnonzero(idx[1:] != idx[:-1]) + 1  # the slots t with positions[t] != positions[t-1]
        if len(moved) > instance.max_moves:
            t = int(moved[instance.max_moves])
            raise PlanError(f"positions[{t}]: move number {instance.max_moves + 1} breaks max_moves = "
                            f"{instance.max_moves} (the plan makes {len(moved)} moves)")


def advance(aoi: np.ndarray, q: np.ndarray, upload, q_upload) -> tuple[np.ndarray, np.ndarray]:
    """One slot of MODEL.md section 3: (A(t+1), q(t+1)) from (A(t), q(t)) when sensor
    ``upload`` (or -1, none) uploads with effective distance ``q_upload``: every age grows by
    one, the uploaded sensor's age becomes 1 and its q the upload's. (q may hold distances or
    any per-sensor label of them, such as the MDP's distance indices.) For several robots
    (section 10) ``upload`` and ``q_upload`` hold one entry per robot, distinct sensors."""
    aoi = np.asarray(aoi) + 1
    q = np.array(q, copy=True)
    if np.ndim(upload) == 0:
        upload, q_upload = (upload,), (q_upload,)
    for u, d in zip(upload, q_upload, strict=True):
        if u >= 0:
            aoi[u] = 1
            q[u] = d
    return aoi, q


def simulate(instance: Instance, plan: Plan | FleetPlan) -> Trajectory:
    """Run a plan through the dynamics; reject illegal plans with a PlanError."""
    idx, sched = check_plan(instance, plan)
    return simulate_indices(instance, idx, sched)


def simulate_indices(instance: Instance, idx: np.ndarray, sched: np.ndarray) -> Trajectory:
    """The dynamics for an already-checked plan given as point indices and schedule (-1 = none):
    (T,) arrays for one robot, (K, T) for a fleet, whose uploads in a slot all count (section 10)."""
    aoi, dist = _dynamics(instance, idx, sched)
    rho = np.array([s.rho for s in instance.sensors])
    power = np.array([s.power_w for s in instance.sensors])
    v = _voi(aoi, dist, rho, power, instance.channel)
    return Trajectory(idx, sched, aoi, dist, v, metrics_of(aoi, v))


def _dynamics(instance: Instance, idx: np.ndarray, sched: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A(t), q(t)) for t = 0..T: ``advance`` applied slot by slot, in closed form. A sensor's
    latest upload before slot t, in slot s, leaves it aged t - s with that upload's distance;
    with none it is aged A_i(0) + t at q_i(0). (At T = 3 x 10^5 the loop over the slots took
    1.5 s; tests/test_simulate.py checks the two agree.)"""
    lat = lattice_mod.build(instance)
    T, N = instance.horizon, instance.n_sensors
    sched2, idx2 = np.atleast_2d(sched), np.atleast_2d(idx)  # (K, T): one row per robot
    latest = np.zeros((T + 1, N), dtype=np.int64)  # 1 + the slot of the latest upload seen in row t
    got = np.zeros((T + 1, N))  # the distance of each upload, in the row after its slot
    k, t = np.nonzero(sched2 >= 0)
    u = sched2[k, t]
    latest[t + 1, u] = t + 1
    got[t + 1, u] = lat.distance[u, idx2[k, t]]
    np.maximum.accumulate(latest, axis=0, out=latest)
    rows = np.arange(T + 1, dtype=np.int64)[:, None]
    a0 = np.array([s.initial_aoi for s in instance.sensors], dtype=np.int64)
    q0 = np.array([instance.initial_distance(i) for i in range(N)], dtype=float)
    aoi = np.where(latest > 0, rows - latest + 1, a0 + rows)
    dist = np.where(latest > 0, got[latest, np.arange(N)], q0)
    return aoi, dist


def slot_by_slot(instance: Instance, idx: np.ndarray, sched: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, q, V) as MODEL.md section 3 states the dynamics: ``advance`` slot by slot, then
    physics.voi on every entry. The reference that ``_dynamics`` and ``_voi`` must equal bit for
    bit (tests/test_simulate.py, benchmarks/simulate_speed.py); too slow to use at long horizons."""
    lat = lattice_mod.build(instance)
    T, N = instance.horizon, instance.n_sensors
    aoi, dist = np.empty((T + 1, N), dtype=np.int64), np.empty((T + 1, N))
    aoi[0] = [s.initial_aoi for s in instance.sensors]
    dist[0] = [instance.initial_distance(i) for i in range(N)]
    for t in range(T):
        u, p = sched[..., t], idx[..., t]  # a sensor and point, or one of each per robot
        aoi[t + 1], dist[t + 1] = advance(aoi[t], dist[t], u, lat.distance[u, p])
    rho = np.array([s.rho for s in instance.sensors])
    power = np.array([s.power_w for s in instance.sensors])
    return aoi, dist, physics.voi(aoi, dist, rho, power, instance.channel)


LONG = 2048  # rows from which ``_voi`` takes each sensor's distinct (age, distance) pairs once


def _voi(aoi: np.ndarray, dist: np.ndarray, rho: np.ndarray, power: np.ndarray, channel) -> np.ndarray:
    """physics.voi of every (slot, sensor). A long plan repeats a sensor's (age, distance) pairs
    (a robot that tours its sensors every 50 slots sees about 50 ages per distance), and libm
    takes a few hundred nanoseconds per call: so from LONG rows on each distinct pair of a
    sensor is valued once (2.4 s at T = 3 x 10^5 before). An entry depends on its own arguments
    alone, so this changes no bit (tests/test_simulate.py). Where libm's calls are compiled
    (voiopt.runtime.libm, about 20 ns an element) every entry is valued: sorting for the distinct pairs
    would cost more (1.2 s at T = 10^6 with four sensors)."""
    if aoi.shape[0] < LONG or physics.compiled(aoi.size):
        return physics.voi(aoi, dist, rho, power, channel)
    out = np.empty(aoi.shape)
    for i in range(aoi.shape[1]):
        dv, di = np.unique(dist[:, i], return_inverse=True)
        keys, back = np.unique(aoi[:, i] * len(dv) + di.reshape(-1), return_inverse=True)  # < 2e6 x (T + 1)
        out[:, i] = physics.voi(keys // len(dv), dv[keys % len(dv)], rho[i], power[i], channel)[back.reshape(-1)]
    return out


def evaluate(instance: Instance, plan: Plan | FleetPlan | dict) -> dict[str, float]:
    """The four metrics of a plan (a Plan or FleetPlan, or a dict holding a plan or a whole
    result); PlanError if the plan is illegal."""
    if not isinstance(plan, (Plan, FleetPlan)):
        plan = Plan.from_dict(plan)
    return simulate(instance, plan).metrics
