"""Exact label-setting dynamic programme with dominance and bounds (docs/dp.md).

A label is (slot, position, per-sensor rank of the latest upload, accumulated objective).
Forward over slots, at every (slot, position) only the non-dominated labels survive; labels
whose admissible bound cannot beat the incumbent are dropped; sensors that can no longer
change the objective are collapsed. The compiled kernels live in ``_dp_core``.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from voiopt import lattice as lattice_mod
from voiopt import objectives, physics
from voiopt.errors import OptionError, VoioptError
from voiopt.instance import Instance
from voiopt.objectives import check_objective
from voiopt.plan import Plan
from voiopt.progress import progress_bar
from voiopt.result import Result
from voiopt.simulate import simulate
from voiopt.solvers.base import (
    DEFAULT_MEMORY_GB,
    check_limits,
    lattice_bytes,
    points_in_range,
    require_memory,
)
from voiopt.stop import TIME_LIMIT, Stop, watch

CHUNK_WORK = 100_000  # (label, upload) pairs per kernel call: the granularity of time checks
DEFAULT_BEAM = 16
QUICK_BEAM = 2  # labels per point of the beam pass that gives the first incumbent
PAIR_TABLE_BYTES = 400e6  # the pairwise bound is skipped where its table would be larger
FAST_BUDGET = 50_000  # labels of the first, unbounded pass before incumbents are computed


@dataclass
class Tables:
    """The instance compiled for the kernels (see the module docstring of _dp_core)."""

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

    @property
    def nbytes(self) -> int:
        """Bytes of the tables (they count against the memory limit with the labels)."""
        return sum(v.nbytes for v in vars(self).values() if isinstance(v, np.ndarray))

    def with_pair_bound(self, max_bytes: float = PAIR_TABLE_BYTES) -> None:
        """Compute the pairwise travel table (skipped if it would exceed ``max_bytes``)."""
        from voiopt.solvers import _dp_core as core

        T, n, N = self.up_rank.shape
        if N > 1 and self.pair.shape[0] == 0 and N * N * T * n * (T + 1) * 8 <= max_bytes:
            self.pair = core.pair_table(self.W, self.up_rank, self.point_steps, self.sensor_points,
                                        self.sensor_point_count)


def table_bytes(instance: Instance) -> float:
    """An upper bound on the bytes of build_tables, from the instance's sizes alone."""
    T, N, n = instance.horizon, instance.n_sensors, lattice_mod.n_points(instance)
    R = 2.0 + T * points_in_range(instance)  # candidate uploads per sensor
    P = points_in_range(instance)
    return (lattice_bytes(instance) + 2.0 * T * n * N + 8.0 * N * R * (T + 1) + 120.0 * N * R
            + 2.0 * N * n * T * (T + 1) + 8.0 * N * P * n)


def build_tables(instance: Instance, objective: str) -> Tables:
    """Candidate uploads per sensor, their ranks by score, and the value table W."""
    from voiopt.solvers import _dp_core as core

    lat = lattice_mod.build(instance)
    T, N, n = instance.horizon, instance.n_sensors, lat.n_points
    aoi = objectives.get(objective).worth == "aoi"
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
    W = np.full((N, R, T + 1), np.inf)
    initial_rank = np.empty(N, dtype=np.int16)
    up_rank = np.full((T, n, N), -1, dtype=np.int16)
    t_grid = np.arange(T + 1)
    for i, sensor in enumerate(instance.sensors):
        rank_of = {c: r for r, c in enumerate(cand_lists[i])}
        s0, d0 = -sensor.initial_aoi, (0.0 if aoi else instance.initial_distance(i))
        initial_rank[i] = rank_of[(s0, d0)]
        slots = np.array([s for s, _ in cand_lists[i]], dtype=float)[:, None]
        dists = np.array([d for _, d in cand_lists[i]])[:, None]
        age = t_grid[None, :] - slots  # (candidates, T+1); only age >= 1 is ever looked up
        later = age >= 1
        if aoi:
            values = -age
        else:
            values = physics.voi(np.maximum(age, 1), dists, sensor.rho, sensor.power_w, instance.channel)
        W[i, : len(slots)] = np.where(later, values, np.inf)
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
                  sensor_points, sensor_point_count, point_steps, np.ascontiguousarray(lat.to_end, dtype=np.int64),
                  lat.budget, int(lat.budget < T - 1))


@dataclass
class SearchOutcome:
    value: float  # internal, -inf if nothing beat the incumbent
    plan: tuple[np.ndarray, np.ndarray] | None  # (positions, schedule) of the best found
    complete: bool  # every label processed: the optimum is max(value, incumbent)
    open_bound: float  # when incomplete: max bound over the labels still open
    labels: int  # labels created (kept after filtering), all layers
    generated: int  # children generated before filtering
    peak_layer: int
    peak_bytes: int
    slots_done: int
    stopped: str | None = None  # why an incomplete pass stopped


def search(tab: Tables, incumbent: float, *, beam: int = 0, collapse: bool = True, bounding: bool = True,
           tdma: bool = True, stop: Stop | None = None, label_budget: int | None = None,
           progress: bool = False) -> SearchOutcome:
    """One forward pass. ``beam`` > 0 keeps only that many labels per point (a heuristic).
    It stops early, incomplete, when the stop rule says so (time, memory of its labels,
    Ctrl-C) or after more than ``label_budget`` labels."""
    stop = stop or Stop()
    from voiopt.solvers import _dp_core as core

    T, n, N = tab.up_rank.shape
    inc = incumbent if bounding else -np.inf
    ranks = tab.initial_rank[None, :].copy()
    acc = np.array([np.inf if tab.mode == core.MIN else 0.0])
    pos = np.array([tab.start], dtype=np.int32)
    left = np.array([tab.budget], dtype=np.int16)  # moves each label may still make
    ub = core.label_bounds(tab.mode, 0, ranks, acc, pos, tab.W, tab.best_rank, collapse, tdma, tab.pair)
    history: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # per slot >= 1: parent, upload, pos
    stored = 0
    peak_layer = 1
    peak_bytes = 0
    labels = 1
    generated = 0
    bar = progress_bar(progress)
    with bar:
        task = bar.add_task("dp beam" if beam else "dp slots", total=T)
        for t in range(T - 1):
            keep = ub > inc
            off = np.zeros(n + 1, dtype=np.int64)
            np.add.at(off, pos[keep].astype(np.int64) + 1, 1)
            off = np.cumsum(off)
            idx = np.flatnonzero(keep)  # labels are grouped by point already
            work = np.zeros(n, dtype=np.int64)
            per_point = (off[1:] - off[:-1]) * (1 + tab.in_range_count)
            for k in range(5):
                nb = tab.neighbors[:, k]
                work += np.where(nb >= 0, per_point[np.maximum(nb, 0)], 0)
            parts = []
            l_ranks, l_acc, l_ub, l_left = ranks[idx], acc[idx], ub[idx], left[idx]
            q_lo = 0
            stopped = False
            while q_lo < n:
                q_hi = q_lo + 1
                total = work[q_lo]
                while q_hi < n and total + work[q_hi] <= CHUNK_WORK:
                    total += work[q_hi]
                    q_hi += 1
                out = _watched(stop, core.expand, tab.mode, t, l_ranks, l_acc, l_ub, l_left, off, tab.neighbors,
                               tab.up_rank, tab.in_range_list, tab.in_range_count, tab.W, tab.best_rank, inc, q_lo,
                               q_hi, beam, collapse, tdma, tab.pair, tab.to_end, tab.budget_lane)
                if out[8]:  # halted by the stop rule: this layer is abandoned, its parents stay open
                    return _incomplete(ub, keep, labels, generated, peak_layer, peak_bytes, t, stop.reason)
                out = (*out[:3], idx[out[3]], *out[4:])
                parts.append(out)
                generated += int(out[7])
                q_lo = q_hi
                if q_lo < n:
                    stopped = _must_stop(stop, tab.nbytes + stored + sum(p[0].nbytes for p in parts),
                                         label_budget, labels + sum(len(p[1]) for p in parts))
                    if stopped:
                        break
            if stopped:
                return _incomplete(ub, keep, labels, generated, peak_layer, peak_bytes, t, stopped)
            new_ranks = np.concatenate([p[0] for p in parts])
            acc = np.concatenate([p[1] for p in parts])
            new_ub = np.concatenate([p[2] for p in parts])
            parent = np.concatenate([p[3] for p in parts])
            upload = np.concatenate([p[4] for p in parts])
            pos = np.concatenate([p[5] for p in parts])
            left = np.concatenate([p[9] for p in parts])
            history.append((parent, upload, pos))
            stored += parent.nbytes + upload.nbytes + pos.nbytes
            layer_bytes = new_ranks.nbytes + acc.nbytes + new_ub.nbytes + left.nbytes
            peak_bytes = max(peak_bytes, stored + layer_bytes + ranks.nbytes)
            ranks, ub = new_ranks, new_ub
            labels += len(acc)
            peak_layer = max(peak_layer, len(acc))
            bar.update(task, advance=1, description=f"dp slots  {len(acc):,} labels{_progress_bound(tab, inc, ub)}")
            if len(acc) == 0:
                return SearchOutcome(-np.inf, None, True, -np.inf, labels, generated, peak_layer, peak_bytes, t + 1)
            stopped = _must_stop(stop, tab.nbytes + stored + layer_bytes, label_budget, labels)
            if t + 1 < T - 1 and stopped:
                return _incomplete(ub, ub > inc, labels, generated, peak_layer, peak_bytes, t + 1, stopped)
        keep = np.flatnonzero(ub > inc)
        value, l, u = core.finish(tab.mode, T - 1, ranks[keep], acc[keep], pos[keep], tab.up_rank,
                                  tab.in_range_list, tab.in_range_count, tab.W)
        bar.update(task, advance=1)
    if l < 0 or value <= inc:
        return SearchOutcome(-np.inf, None, True, -np.inf, labels, generated, peak_layer, peak_bytes, T)
    # reconstruct through the parent pointers
    positions = np.empty(T, dtype=np.int64)
    schedule = np.full(T, -1, dtype=np.int64)
    schedule[T - 1] = u
    label = int(keep[l])
    for t in range(T - 1, 0, -1):
        parent, upload, at = history[t - 1]
        positions[t] = at[label]
        schedule[t - 1] = upload[label]
        label = int(parent[label])
    positions[0] = tab.start
    return SearchOutcome(float(value), (positions, schedule), True, -np.inf, labels, generated, peak_layer,
                         peak_bytes, T)


def _progress_bound(tab: Tables, inc: float, ub: np.ndarray) -> str:
    """Incumbent, proven bound and gap for the progress bar: every completion that could beat
    the incumbent passes through a label of the current layer, so max(incumbent, the layer's
    largest bound) bounds the optimum now."""
    if not np.isfinite(inc):
        return ""
    bound = max(inc, float(ub.max())) if len(ub) else inc
    best, top = _external(tab, inc), _external(tab, bound)
    return f"  best {best:.6g}  bound {top:.6g}  gap {100 * objectives.gap(best, top):.3g} %"


WATCH_S = 0.05  # how often the stop rule is checked while a kernel runs


def _watched(stop: Stop, kernel, *args):
    """Run a nogil kernel (whose last argument is a halt flag) in a thread; the calling thread
    checks the stop rule every WATCH_S seconds and raises the flag, so a time limit or Ctrl-C
    stops even one long kernel call within a fraction of a second."""
    halt = np.zeros(1, dtype=np.uint8)
    box: list = []
    worker = threading.Thread(target=lambda: box.append(kernel(*args, halt)), daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(WATCH_S)
            if stop.check() is not None:
                halt[0] = 1
    finally:  # a second Ctrl-C raises here: the kernel must not run on behind it
        if worker.is_alive():
            halt[0] = 1
    if not box:
        raise RuntimeError("dp: a kernel failed in its thread")
    return box[0]


def _incomplete(ub, keep, labels, generated, peak_layer, peak_bytes, t, stopped) -> SearchOutcome:
    open_bound = float(ub[keep].max()) if keep.any() else -np.inf
    return SearchOutcome(-np.inf, None, False, open_bound, labels, generated, peak_layer, peak_bytes, t, stopped)


LABEL_BUDGET = "label budget"  # a pass's own budget, not a stop of the solve


def _must_stop(stop: Stop, used: float, label_budget, labels) -> str | None:
    reason = stop.check(used)
    if reason is None and label_budget is not None and labels > label_budget:
        return LABEL_BUDGET
    return reason


def _internal(tab: Tables, value: float) -> float:
    return value * tab.to_internal


def _external(tab: Tables, value: float) -> float:
    return value / tab.to_internal


_WARM = False


def warm_up() -> float:
    """Compile (or load from numba's cache) the kernels once per process on a tiny instance, so
    that runtime_s measures the search alone; returns the seconds this took (0 once done)."""
    global _WARM
    if _WARM:
        return 0.0
    _WARM = True
    from voiopt.generate import generate

    t0 = time.perf_counter()
    tiny = generate(2, 4, width=2.0, height=2.0, seed=0, name="warm-up")
    for objective in objectives.OBJECTIVES:
        solve(tiny, objective, fast_budget=1)  # every pass and bound runs once
    return time.perf_counter() - t0


def solve(
    instance: Instance,
    objective: str,
    *,
    progress: bool = False,
    time_limit: float | None = None,
    memory_limit: float = DEFAULT_MEMORY_GB,
    warm_start: Plan | None = None,
    beam: int = DEFAULT_BEAM,
    greedy: bool = True, collapse: bool = True, bounding: bool = True, tdma: bool = True, pair_bound: bool = True,
    fast_budget: int = FAST_BUDGET,
    quick_beam: int = QUICK_BEAM,
) -> Result:
    """Optimal plan by label setting; on a time or memory limit (GB, of the labels) or Ctrl-C,
    the best plan and a proven bound, with the stop's reason as the status.

    Small instances are solved by one pass with no incumbent but the warm start: if that pass
    needs more than ``fast_budget`` labels it is abandoned, incumbents are computed (greedy and
    a beam pass of width ``beam``) and a bounded pass proves the optimum. ``greedy``,
    ``collapse`` and ``bounding`` switch ingredients off for measurements (docs/dp.md)."""
    if instance.fleet:  # several robots: the joint programme (docs/dp.md, "Several robots")
        from voiopt.solvers import fleet_dp

        one_robot = dict(greedy=(greedy, True), collapse=(collapse, True), tdma=(tdma, True),
                         pair_bound=(pair_bound, True), fast_budget=(fast_budget, FAST_BUDGET),
                         quick_beam=(quick_beam, QUICK_BEAM))
        for key, (given, default) in one_robot.items():
            if given != default:
                raise OptionError(f"--{key.replace('_', '-')}: an option of the one-robot dp, not of dp for several robots")
        return fleet_dp.solve(instance, objective, progress=progress, time_limit=time_limit, memory_limit=memory_limit,
                              warm_start=warm_start, beam=beam, bounding=bounding)
    check_objective(objective)
    check_limits(time_limit, memory_limit)
    require_memory(table_bytes(instance), memory_limit, "dp's tables")
    startup_s = warm_up()
    with watch(time_limit, memory_limit) as stop:
        return _solve(instance, objective, stop, startup_s, warm_start=warm_start, beam=beam, greedy=greedy,
                      collapse=collapse, bounding=bounding, tdma=tdma, pair_bound=pair_bound,
                      fast_budget=fast_budget, quick_beam=quick_beam, progress=progress)


def _solve(instance: Instance, objective: str, stop: Stop, startup_s: float, *, warm_start, beam, greedy,
           collapse, bounding, tdma, pair_bound, fast_budget, quick_beam, progress) -> Result:
    tab = build_tables(instance, objective)

    best_plan: Plan | None = None
    best_value = -np.inf  # internal (maximised) units
    incumbents: list[tuple[str, float]] = []

    def offer(plan: Plan, source: str) -> None:
        nonlocal best_plan, best_value
        v = _internal(tab, simulate(instance, plan).metrics[objective])
        if best_plan is None or v > best_value:
            best_plan, best_value = plan, v
        incumbents.append((source, _external(tab, v)))

    def inc() -> float:
        return best_value if bounding else -np.inf

    if warm_start is not None:
        offer(warm_start, "warm_start")
    passes = []
    # the fast passes use only the cheap bound: at the paper's scale the tight ones cost more than they save
    limits = dict(collapse=collapse, bounding=bounding, tdma=False, stop=stop)

    def beam_pass(width: int) -> None:  # a heuristic pass: at most ``width`` labels per point
        b = search(tab, inc(), beam=width, **limits)
        passes.append((f"beam {width}", b))
        if b.plan is not None:
            offer(Plan.from_indices(instance, *b.plan), f"beam {width}")

    if quick_beam > 0:  # a nearly free first incumbent: QUICK_BEAM labels per point
        beam_pass(quick_beam)
    out = search(tab, inc(), label_budget=fast_budget, progress=progress, **limits)
    passes.append(("fast", out))
    if not out.complete:
        plan = _greedy_plan(instance, objective, stop) if greedy and not stop.requested else None
        if plan is not None:
            offer(plan, "greedy")
        if pair_bound and tdma and out.stopped == LABEL_BUDGET:
            room = PAIR_TABLE_BYTES if stop.memory_bytes is None else stop.memory_bytes - 2 * tab.nbytes
            tab.with_pair_bound(min(PAIR_TABLE_BYTES, room))  # within the memory limit, with room for labels
        limits["tdma"] = tdma
        if beam > 0 and out.stopped == LABEL_BUDGET:
            beam_pass(beam)
        if out.stopped == LABEL_BUDGET:
            out = search(tab, inc(), progress=progress, **limits)
            passes.append(("bounded", out))
    if out.plan is not None:
        plan = Plan.from_indices(instance, *out.plan)
        found = _internal(tab, simulate(instance, plan).metrics[objective])
        incumbents.append(("dp", _external(tab, found)))
        if best_plan is None or found > best_value:
            best_plan, best_value = plan, found
        else:  # the incumbent matches to rounding: keep it, count the DP value in the bound
            best_value = max(best_value, out.value)
    if best_plan is None:  # stopped before any plan: no uploads, the fewest moves to end (or staying)
        T = instance.horizon
        lat = lattice_mod.build(instance)
        offer(Plan.from_indices(instance, [tab.start, *lat.walk_home(tab.start, T - 1)], np.full(T, -1)), "idle")
    if out.complete:
        bound_internal, status = max(best_value, out.value), "optimal"
    else:
        bound_internal, status = max(best_value, out.open_bound), stop.reason or TIME_LIMIT
    solver = {
        "passes": {name: dict(labels=p.labels, children_generated=p.generated, peak_layer_labels=p.peak_layer,
                              slots_done=p.slots_done, complete=p.complete)
                   for name, p in passes},
        "labels": sum(p.labels for _, p in passes),
        "peak_label_bytes": max(p.peak_bytes for _, p in passes),
        "incumbents": incumbents,
        "options": {"beam": beam, "greedy": greedy, "collapse": collapse, "bounding": bounding, "tdma": tdma,
                    "pair_bound": tab.pair.shape[0] > 0,
                    "fast_budget": fast_budget, "time_limit": stop.time_limit, "memory_limit": stop.memory_limit},
    }
    solver["startup_s"] = startup_s
    if not out.complete:
        solver["stopped"] = stop.describe()
    return Result.from_plan(instance, "dp", objective, best_plan, status=status, bound=_external(tab, bound_internal),
                            runtime_s=stop.elapsed(), solver=solver)


def _greedy_plan(instance: Instance, objective: str, stop: Stop) -> Plan | None:
    """Greedy's plan as an incumbent, within the time left (its own stop rule follows ours)."""
    from voiopt.solvers.baselines import greedy

    left = stop.remaining()
    if left is not None and left <= 0:
        return None
    return greedy(instance, objective, time_limit=left, memory_limit=stop.memory_limit).plan
