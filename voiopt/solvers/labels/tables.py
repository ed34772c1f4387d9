"""What the one-robot programme (dp.py) and the two-robot one (fleet_dp.py) share: the network
compiled into ranks and worth tables (they depend on the sensors and the lattice, not on a
robot), a slot's work cut into kernel calls, and the watched call of a nogil kernel that
honours the stop rule."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field

import numpy as np

from voiopt import objectives
from voiopt.core import physics
from voiopt.core.instance import Instance
from voiopt.errors import VoioptError
from voiopt.grid import lattice as lattice_mod
from voiopt.objectives import Worth
from voiopt.runtime.stop import Stop, halt_if_asked
from voiopt.solvers.base import lattice_bytes, points_in_range

CHUNK_WORK = 100_000  # (label, upload) pairs per kernel call: the granularity of time checks
PAIR_TABLE_BYTES = 400e6  # the pairwise bound is skipped where its table would be larger


@dataclass
class Tables:
    """The instance compiled for the kernels (see the module docstring of labels.kernels)."""

    mode: int  # SUM or MIN
    initial_rank: np.ndarray  # (N,) int16
    up_rank: np.ndarray  # (T, n, N) int16, -1 where out of range
    W: np.ndarray  # (N, R, T+1) float64, row R-1 = collapsed (+inf)
    best_rank: np.ndarray  # (N, n, T, T+1) int16
    in_range_list: np.ndarray  # (n, N) sensors in range of each point
    in_range_count: np.ndarray  # (n,)
    neighbors: np.ndarray  # (n, 5)
    start: int
    to_internal: float  # objective value * to_internal = internal (maximised) value
    objective: str
    sensor_points: np.ndarray  # (N, P) in-range points of each sensor
    sensor_point_count: np.ndarray  # (N,)
    point_steps: np.ndarray  # (N, P, n) fewest moves from each in-range point to every point
    to_end: np.ndarray  # (n,) fewest moves to end (0 without one), MODEL.md section 9
    budget: int  # the moves a plan may make, min(max_moves, T - 1)
    budget_lane: int  # 1 when max_moves binds: the moves left join the dominance test
    pair: np.ndarray = field(default_factory=lambda: np.empty((0, 0, 0, 0, 0)))  # pair_table, or empty
    steps: np.ndarray = field(default_factory=lambda: np.empty((0, 0), dtype=np.int64))  # range_steps, or empty

    def internal(self, value: float) -> float:
        """An objective value in the kernels' (maximised) units."""
        return value * self.to_internal

    def external(self, value: float) -> float:
        """A value in the kernels' units in the objective's own."""
        return value / self.to_internal

    @property
    def nbytes(self) -> int:
        """Bytes of the tables (they count against the memory limit with the labels)."""
        return sum(v.nbytes for v in vars(self).values() if isinstance(v, np.ndarray))

    def with_tour_bound(self) -> None:
        """Compute the moves between sensors' ranges that the tour bound needs (one robot only)."""
        from voiopt.solvers.labels import bounds

        if self.up_rank.shape[2] > 1 and self.steps.shape[0] == 0:
            self.steps = bounds.range_steps(self.point_steps, self.sensor_points, self.sensor_point_count)

    def with_pair_bound(self, max_bytes: float = PAIR_TABLE_BYTES) -> None:
        """Compute the pairwise travel table (skipped if it would exceed ``max_bytes``)."""
        from voiopt.solvers.labels import bounds

        T, n, N = self.up_rank.shape
        if N > 1 and self.pair.shape[0] == 0 and N * N * T * n * (T + 1) * 8 <= max_bytes:
            self.pair = bounds.pair_table(self.W, self.up_rank, self.point_steps, self.sensor_points,
                                        self.sensor_point_count)


def table_bytes(instance: Instance) -> float:
    """An upper bound on the bytes of build_tables, from the instance's sizes alone."""
    T, N, n = instance.horizon, instance.n_sensors, lattice_mod.n_points(instance)
    R = 2.0 + T * points_in_range(instance)  # candidate uploads per sensor
    P = points_in_range(instance)
    return (lattice_bytes(instance) + 2.0 * T * n * N + 8.0 * N * R * (T + 1) + 120.0 * N * R
            + 2.0 * N * n * T * (T + 1) + 8.0 * N * P * n)


VOI_BLOCK = 1 << 17  # worths of W computed between two checks of the stop rule (0.05 s, 0.15 s on a busy machine)


def build_tables(instance: Instance, objective: str, stop: Stop | None = None) -> Tables:
    """Candidate uploads per sensor, their ranks by score, and the value table W. W's worths
    grow as T^2 (libm per entry: 12M of them, 6 s, at T = 1108 with 3 sensors), so ``stop`` is
    checked after every VOI_BLOCK of them (never for a smaller table): voiopt.runtime.stop.Stopped (the
    blocks change no bit). Until 2026-12-02 it was checked only once 2^18 had been counted, and a
    block held 2^18 less a few: every second block; and each sensor's ages, worths and mask were
    made whole first (about 800 MB of first writes at T = 1633): 1.7 s for a 0.3 s limit on a
    busy machine."""
    from voiopt.solvers.labels import kernels as core

    lat = lattice_mod.build(instance)
    T, N, n = instance.horizon, instance.n_sensors, lat.n_points
    aoi = objectives.get(objective).worth == Worth.AOI
    # candidates (s, d): an upload in slot s at distance d; the held packet is s = -A_i(0), d = q_i(0)
    cand_lists = []
    for i, sensor in enumerate(instance.sensors):
        s0, d0 = -sensor.initial_aoi, instance.initial_distance(i)
        if aoi:
            cands = [(s0, 0.0)] + [(s, 0.0) for s in range(T)]  # only the slot matters
            keys = [float(s) for s, _ in cands]
        else:
            dists = sorted(set(float(d) for d in lat.distance[i][lat.in_range[i]]))
            cands = [(s0, d0)] + [(s, d) for s in range(T) for d in dists]
            log_rho = math.log(sensor.rho)
            log_c = {d: float(np.log(physics.distance_factor(sensor.power_w, d, instance.channel)))
                     for d in set(dists) | {d0}}
            keys = [-s * log_rho + log_c[d] for s, d in cands]
        order = sorted(range(len(cands)), key=lambda k: (keys[k], cands[k][0], -cands[k][1]))
        cand_lists.append([cands[k] for k in order])
    R = max(len(c) for c in cand_lists) + 1
    if R >= np.iinfo(np.int16).max:
        raise VoioptError(f"dp: too many candidate uploads per sensor ({R}) for 16-bit ranks (horizon too long)")
    W = np.empty((N, R, T + 1))  # written sensor by sensor: at T = 1633 it is 341 MB, a second of first writes
    big = stop is not None and W.size >= VOI_BLOCK  # a small table is built in full
    initial_rank = np.empty(N, dtype=np.int16)
    up_rank = np.full((T, n, N), -1, dtype=np.int16)
    t_grid = np.arange(T + 1)
    for i, sensor in enumerate(instance.sensors):
        if big and i:
            halt_if_asked(stop)
        rank_of = {c: r for r, c in enumerate(cand_lists[i])}
        s0, d0 = -sensor.initial_aoi, (0.0 if aoi else instance.initial_distance(i))
        initial_rank[i] = rank_of[(s0, d0)]
        slots = np.array([s for s, _ in cand_lists[i]], dtype=float)[:, None]
        dists = np.array([d for _, d in cand_lists[i]])[:, None]
        rows = max(1, VOI_BLOCK // (T + 1))  # candidates a block: written straight into W, no T^2 temporaries
        for r in range(0, len(slots), rows):
            if big and r:
                halt_if_asked(stop)
            age = t_grid[None, :] - slots[r:r + rows]  # only age >= 1 is ever looked up
            values = -age if aoi else physics.voi(np.maximum(age, 1), dists[r:r + rows], sensor.rho, sensor.power_w,
                                                   instance.channel)
            W[i, r:r + len(age)] = np.where(age >= 1, values, np.inf)
        W[i, len(slots):] = np.inf
        for p in np.flatnonzero(lat.in_range[i]):
            d = 0.0 if aoi else float(lat.distance[i, p])
            for s in range(T):
                up_rank[s, p, i] = rank_of[(s, d)]
    in_range_count = lat.in_range.sum(axis=0).astype(np.int64)
    in_range_list = np.full((n, max(N, 1)), -1, dtype=np.int64)
    for p in range(n):
        ids = np.flatnonzero(lat.in_range[:, p])
        in_range_list[p, : len(ids)] = ids
    sensor_point_count = lat.in_range.sum(axis=1).astype(np.int64)
    sensor_points = np.zeros((N, max(1, int(sensor_point_count.max()))), dtype=np.int64)
    for i in range(N):
        ids = np.flatnonzero(lat.in_range[i])
        sensor_points[i, : len(ids)] = ids
    point_steps = np.zeros((N, sensor_points.shape[1], n), dtype=np.int64)  # padding rows stay 0, never read
    rows: dict[int, np.ndarray] = {}  # one search per distinct point: sensors share in-range points
    for i in range(N):
        for j, q in enumerate(sensor_points[i, : sensor_point_count[i]].tolist()):
            if q not in rows:
                rows[q] = lat.steps_from(q)
            point_steps[i, j] = rows[q]
    best_rank = core.best_rank_table(up_rank, point_steps, sensor_points, sensor_point_count)
    mode = core.SUM if objectives.get(objective).per_slot else core.MIN
    to_internal = (T if mode == core.SUM else 1.0) * (-1.0 if aoi else 1.0)
    return Tables(mode, initial_rank, up_rank, W, best_rank, in_range_list, in_range_count,
                  np.ascontiguousarray(lat.neighbors, dtype=np.int64), lat.start, to_internal, objective,
                  sensor_points, sensor_point_count, point_steps, np.array(lat.to_end, dtype=np.int64),  # writable: one numba type
                  lat.budget, int(lat.budget < T - 1))


WATCH_S = 0.05  # how often the stop rule is checked while a kernel runs


def run_of(work: np.ndarray, lo: int, size: float) -> tuple[int, float]:
    """(hi, total): the longest run lo .. hi-1 of ``work`` (one entry at least) whose total is at
    most ``size``; the target points (or pairs of points) of one kernel call."""
    hi, total = lo + 1, work[lo]
    while hi < len(work) and total + work[hi] <= size:
        total += work[hi]
        hi += 1
    return hi, total


def watched(stop: Stop, kernel, *args):
    """Run a nogil kernel (whose last argument is a halt flag) in a thread; the calling thread
    checks the stop rule every WATCH_S seconds and raises the flag, so a time limit or Ctrl-C
    stops even one long kernel call within a fraction of a second."""
    return watched_all(stop, kernel, [args], 1)[0]


def watched_all(stop: Stop, kernel, calls: list[tuple], threads: int) -> list:
    """``watched`` for several calls of one nogil kernel, up to ``threads`` of them at once
    (they run in parallel, since the kernel releases the GIL); the results in the calls' order,
    whatever order they finish in. One halt flag stops them all: a call made after it is up
    returns at once, halted, and so does every call when the stop rule says stop before they
    start (a label allowance spent: the same on every run)."""
    halt = np.array([stop.check() is not None], dtype=np.uint8)
    results: list = [None] * len(calls)  # None until its call returns
    todo = iter(range(len(calls)))
    lock = threading.Lock()

    def work() -> None:
        while True:
            with lock:
                i = next(todo, None)
            if i is None:
                return
            results[i] = kernel(*calls[i], halt)

    workers = [threading.Thread(target=work, daemon=True) for _ in range(max(1, min(threads, len(calls))))]
    for w in workers:
        w.start()
    try:
        for w in workers:
            while w.is_alive():
                w.join(WATCH_S)
                if stop.check() is not None:
                    halt[0] = 1
    finally:  # a second Ctrl-C raises here: the kernels must not run on behind it
        if any(w.is_alive() for w in workers):
            halt[0] = 1
    if any(r is None for r in results):
        raise RuntimeError("dp: a kernel failed in its thread")
    return results


def progress_text(best: float, bound: float) -> str:
    """Best value, bound and gap in the objective's units, as dp's progress bars show them."""
    return f"  best {best:.6g}  bound {bound:.6g}  gap {objectives.show_gap(objectives.gap(best, bound))}"
