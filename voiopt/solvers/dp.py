"""Exact label-setting dynamic programme with dominance and bounds (docs/dp.md).

A label is (slot, position, per-sensor rank of the latest upload, accumulated objective).
Forward over slots, at every (slot, position) only the non-dominated labels survive; labels
whose admissible bound cannot beat the incumbent are dropped; sensors that can no longer
change the objective are collapsed. The compiled kernels live in ``_dp_core``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import partial

import numpy as np

from voiopt import lattice as lattice_mod
from voiopt import objectives
from voiopt.errors import OptionError
from voiopt.instance import Instance
from voiopt.objectives import check_objective
from voiopt.plan import Plan
from voiopt.progress import progress_bar
from voiopt.result import Result
from voiopt.simulate import simulate
from voiopt.solvers import _dp_pattern, _dp_subsets
from voiopt.solvers._dp_shared import (
    CHUNK_WORK,
    PAIR_TABLE_BYTES,
    Tables,
    build_tables,
    progress_text,
    run_of,
    table_bytes,
    watched_all,
)
from voiopt.solvers.base import (
    DEFAULT_MEMORY_GB,
    check_limits,
    check_threads,
    require_memory,
    warm_up_once,
)
from voiopt.stop import TIME_LIMIT, Stop, watch

__all__ = ["CHUNK_WORK", "PAIR_TABLE_BYTES", "Tables", "build_tables", "table_bytes", "search", "solve", "warm_up"]

DEFAULT_BEAM = 16
QUICK_BEAM = 2  # labels per point of the beam pass that gives the first incumbent
WIDEN = 4  # the incumbent's beam pass doubles its width up to WIDEN * beam,
WIDEN_SHARE = 0.1  # while the next pass is predicted (2.5 x the last) to take at most this share of the time left
FAST_BUDGET = 50_000  # labels of the first, unbounded pass before incumbents are computed
PATTERN_SENSORS = 3  # the bounded pass's pattern database: the first subset solved with this many sensors or more


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


def _chunks(work: np.ndarray, threads: int) -> list[tuple[int, int]]:
    """Runs (q_lo, q_hi) of target points of about CHUNK_WORK (label, upload) pairs each (at
    least one point): one kernel call each. With threads, smaller ones, so that a slot gives
    each thread about four to do."""
    size = CHUNK_WORK if threads == 1 else min(CHUNK_WORK, max(1, int(work.sum()) // (4 * threads)))
    chunks, q_lo = [], 0
    while q_lo < len(work):
        q_hi, _ = run_of(work, q_lo, size)
        chunks.append((q_lo, q_hi))
        q_lo = q_hi
    return chunks


def search(tab: Tables, incumbent: float, *, beam: int = 0, collapse: bool = True, bounding: bool = True,
           tdma: bool = True, stop: Stop | None = None, label_budget: int | None = None,
           progress: bool = False, threads: int = 1, record: list | None = None,
           patterns: tuple = ()) -> SearchOutcome:
    """One forward pass. ``beam`` > 0 keeps only that many labels per point (a heuristic).
    It stops early, incomplete, when the stop rule says so (time, memory of its labels,
    Ctrl-C) or after more than ``label_budget`` labels. A slot's target points are expanded in
    chunks, ``threads`` chunks at a time: they are independent, so the labels are the same
    whatever ``threads`` is. ``record`` (a list) receives each slot's expanded labels as
    (ranks, acc, moves left, points, offsets by point), the last slot's those that beat the
    incumbent; ``patterns`` (_dp_pattern.Pattern) tighten each new layer's bounds. A pattern
    built at threshold z needs ``incumbent`` >= z, and then a stopped pass's ``open_bound``
    bounds the optimum only together with z (max of the two): see _dp_pattern."""
    stop = stop or Stop()
    from voiopt.solvers import _dp_core as core

    T, n, N = tab.up_rank.shape
    inc = incumbent if bounding else -np.inf
    ranks = tab.initial_rank[None, :].copy()
    acc = np.array([np.inf if tab.mode == core.MIN else 0.0])
    pos = np.array([tab.start], dtype=np.int32)
    left = np.array([tab.budget], dtype=np.int16)  # moves each label may still make
    ub = core.label_bounds(tab.mode, 0, ranks, acc, pos, tab.W, tab.best_rank, collapse, tdma, tab.pair,
                            tab.steps)
    history: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # per slot >= 1: parent, upload, pos
    stored = 0
    fixed = tab.nbytes + sum(pattern.nbytes for pattern in patterns)  # held for the whole pass
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
            if record is not None:
                record.append((l_ranks, l_acc, l_left, pos[idx], off))
                stored += l_ranks.nbytes + l_acc.nbytes + l_left.nbytes + 4 * len(idx) + off.nbytes
            chunks = _chunks(work, threads)
            stopped = False
            for b in range(0, len(chunks), threads):  # memory and labels are checked between batches
                outs = watched_all(stop, core.expand, [
                    (tab.mode, t, l_ranks, l_acc, l_ub, l_left, off, tab.neighbors, tab.up_rank, tab.in_range_list,
                     tab.in_range_count, tab.W, tab.best_rank, inc, q_lo, q_hi, beam, collapse, tdma, tab.pair,
                     tab.steps, tab.to_end, tab.budget_lane) for q_lo, q_hi in chunks[b:b + threads]], threads)
                if any(out[8] for out in outs):  # halted by the stop rule: the layer is abandoned, its parents stay open
                    return _incomplete(ub, keep, labels, generated, peak_layer, peak_bytes, t, stop.reason)
                for out in outs:
                    parts.append((*out[:3], idx[out[3]], *out[4:]))
                    generated += int(out[7])
                if b + threads < len(chunks):
                    stopped = _must_stop(stop, fixed + stored + sum(p[0].nbytes for p in parts),
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
            for pattern in patterns:
                ub = pattern.bound(stop, t + 1, ranks, acc, pos, left, ub, tab.W.shape[1] - 1)
            labels += len(acc)
            peak_layer = max(peak_layer, len(acc))
            bar.update(task, advance=1, description=f"dp slots  {len(acc):,} labels{_progress_bound(tab, inc, ub)}")
            if len(acc) == 0:
                return SearchOutcome(-np.inf, None, True, -np.inf, labels, generated, peak_layer, peak_bytes, t + 1)
            stopped = _must_stop(stop, fixed + stored + layer_bytes, label_budget, labels)
            if t + 1 < T - 1 and stopped:
                return _incomplete(ub, ub > inc, labels, generated, peak_layer, peak_bytes, t + 1, stopped)
        keep = np.flatnonzero(ub > inc)
        if record is not None:
            last = np.zeros(n + 1, dtype=np.int64)
            np.add.at(last, pos[keep].astype(np.int64) + 1, 1)
            record.append((ranks[keep], acc[keep], left[keep], pos[keep], np.cumsum(last)))
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
    return progress_text(_external(tab, inc), _external(tab, bound))



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


def warm_up() -> float:
    """Compile (or load from numba's cache) the kernels once per process on a tiny instance, so
    that runtime_s measures the search alone; returns the seconds this took (0 once done)."""

    def load():
        from voiopt.generate import generate

        tiny = generate(2, 4, width=2.0, height=2.0, seed=0, name="warm-up")
        for objective in objectives.OBJECTIVES:
            solve(tiny, objective, fast_budget=1)  # every pass and bound runs once

    return warm_up_once("dp", load)


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
    tour_bound: bool = True, subsets: bool = True, patterns: bool = True,
    fast_budget: int = FAST_BUDGET,
    quick_beam: int = QUICK_BEAM,
    threads: int = 1,
) -> Result:
    """Optimal plan by label setting; on a time or memory limit (GB, of the labels) or Ctrl-C,
    the best plan and a proven bound, with the stop's reason as the status.

    Small instances are solved by one pass with no incumbent but the warm start: if that pass
    needs more than ``fast_budget`` labels it is abandoned, incumbents are computed (greedy and
    a beam pass of width ``beam``) and a bounded pass proves the optimum. ``greedy``,
    ``collapse`` and ``bounding`` switch ingredients off for measurements (docs/dp.md).
    ``threads`` > 1 expands that many chunks of a slot at once: the same labels and plan, sooner
    on as many cores."""
    if instance.fleet:  # several robots: the joint programme (docs/dp.md, "Several robots")
        from voiopt.solvers import fleet_dp

        one_robot = dict(greedy=(greedy, True), collapse=(collapse, True), tdma=(tdma, True),
                         pair_bound=(pair_bound, True), tour_bound=(tour_bound, True),
                         subsets=(subsets, True), patterns=(patterns, True), fast_budget=(fast_budget, FAST_BUDGET),
                         quick_beam=(quick_beam, QUICK_BEAM), threads=(threads, 1))
        for key, (given, default) in one_robot.items():
            if given != default:
                raise OptionError(f"--{key.replace('_', '-')}: an option of the one-robot dp, not of dp for several robots")
        # the beam: the one-robot default (labels per point) becomes the fleet's (per point pair)
        return fleet_dp.solve(instance, objective, progress=progress, time_limit=time_limit, memory_limit=memory_limit,
                              warm_start=warm_start, beam=fleet_dp.FLEET_BEAM if beam == DEFAULT_BEAM else beam,
                              bounding=bounding)
    check_objective(objective)
    check_limits(time_limit, memory_limit)
    check_threads(threads)
    require_memory(table_bytes(instance), memory_limit, "dp's tables")
    startup_s = warm_up()
    with watch(time_limit, memory_limit) as stop:
        return _solve(instance, objective, stop, startup_s, warm_start=warm_start, beam=beam, greedy=greedy,
                      collapse=collapse, bounding=bounding, tdma=tdma, pair_bound=pair_bound,
                      tour_bound=tour_bound, subsets=subsets, patterns=patterns, fast_budget=fast_budget,
                      quick_beam=quick_beam,
                      progress=progress, threads=int(threads))


def _solve(instance: Instance, objective: str, stop: Stop, startup_s: float, *, warm_start, beam, greedy,
           collapse, bounding, tdma, pair_bound, tour_bound, subsets, patterns, fast_budget, quick_beam,
           progress, threads) -> Result:
    tab = build_tables(instance, objective)
    if tour_bound and tdma and objectives.get(objective).per_slot:  # the bottleneck ones: slower, no tighter (docs/dp.md)
        tab.with_tour_bound()

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
    limits = dict(collapse=collapse, bounding=bounding, tdma=False, stop=stop, threads=threads)

    def beam_pass(width: int, **kw) -> None:  # a heuristic pass: at most ``width`` labels per point
        b = search(tab, inc(), beam=width, **{**limits, **kw})
        passes.append((f"beam {width}", b))
        if b.plan is not None:
            offer(Plan.from_indices(instance, *b.plan), f"beam {width}")

    relaxed, subset_runs = np.inf, []  # the subsets' bound (internal units) and their records, if they ran
    pattern_runs: list[dict] = []
    if quick_beam > 0:  # a nearly free first incumbent: QUICK_BEAM labels per point
        beam_pass(quick_beam)
    # one thread: the label budget is checked after each chunk, and this pass is short
    out = search(tab, inc(), label_budget=fast_budget, progress=progress, **{**limits, "threads": 1})
    passes.append(("fast", out))
    if not out.complete:
        plan = _greedy_plan(instance, objective, stop) if greedy and not stop.requested else None
        if plan is not None:
            offer(plan, "greedy")
        if pair_bound and tdma and out.stopped == LABEL_BUDGET:
            tab.with_pair_bound(_pair_room(stop, tab))
        limits["tdma"] = tdma
        if beam > 0 and out.stopped == LABEL_BUDGET:
            _widening(beam_pass, beam, stop)
        if subsets and bounding and out.stopped == LABEL_BUDGET:
            def solve_subset(sub: Instance, seconds: float, warm: Plan | None) -> Result:
                return solve(sub, objective, time_limit=seconds, memory_limit=stop.memory_limit, warm_start=warm,
                             subsets=False, threads=threads)

            relaxed, subset_runs = _dp_subsets.relax(instance, objective, tab, stop, offer, lambda: (best_plan, best_value),
                                        solve_subset, progress)
        if out.stopped == LABEL_BUDGET and not _dp_subsets.reaches(best_value, relaxed):
            out, relaxed = _bounded(instance, objective, tab, stop, subset_runs if patterns else [], inc, relaxed,
                                    offer, passes, pattern_runs, progress, limits,
                                    partial(_pattern_tables, objective=objective, tour=tab.steps.shape[0] > 0,
                                            pair_bytes=_pair_room(stop, tab) if pair_bound and tdma else 0.0))
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
    elif _dp_subsets.reaches(best_value, relaxed):  # a plan as good as a subset's bound
        bound_internal, status = max(best_value, relaxed), "optimal"
    else:
        bound_internal, status = max(best_value, min(out.open_bound, relaxed)), stop.reason or TIME_LIMIT
    solver = {
        "passes": {name: dict(labels=p.labels, children_generated=p.generated, peak_layer_labels=p.peak_layer,
                              slots_done=p.slots_done, complete=p.complete)
                   for name, p in passes},
        "labels": sum(p.labels for _, p in passes) + sum(r["labels"] for r in subset_runs + pattern_runs),
        "peak_label_bytes": max(p.peak_bytes for _, p in passes),
        "incumbents": incumbents,
        "options": {"beam": beam, "greedy": greedy, "collapse": collapse, "bounding": bounding, "tdma": tdma,
                    "pair_bound": tab.pair.shape[0] > 0, "tour_bound": tab.steps.shape[0] > 0, "subsets": subsets,
                    "patterns": patterns,
                    "fast_budget": fast_budget, "time_limit": stop.time_limit, "memory_limit": stop.memory_limit,
                    "threads": threads},
    }
    solver["startup_s"] = startup_s
    if np.isfinite(relaxed):
        solver["subset_bound"] = _external(tab, relaxed)
    if subset_runs:
        solver["subsets"] = subset_runs
    if pattern_runs:
        solver["patterns"] = pattern_runs
    if status != "optimal":
        solver["stopped"] = stop.describe()
    return Result.from_plan(instance, "dp", objective, best_plan, status=status, bound=_external(tab, bound_internal),
                            runtime_s=stop.elapsed(), solver=solver)


def _bounded(instance: Instance, objective: str, tab: Tables, stop: Stop, subset_runs: list[dict], inc, relaxed: float,
             offer, passes: list, pattern_runs: list, progress: bool, limits: dict,
             tables) -> tuple[SearchOutcome, float]:
    """The bounded pass, with the pattern database (``_dp_pattern``) of the first subset of at
    least PATTERN_SENSORS sensors that the subsets solved, if any. While the subsets' bound is
    above the incumbent, a first pass searches only above the midpoint z between them: it finds
    the optimum if that is above z (a pass is exact above its threshold) or proves the optimum
    at most z, and then the last pass starts from the incumbent. Returns the last pass and the
    bound proven (internal units); ``pattern_runs`` receives a record of each pattern built.
    ``tables(subset)`` compiles a subset with the bounds of the whole's bounded pass."""
    sensors = next((r["sensors"] for r in subset_runs
                    if r["status"] == "optimal" and len(r["sensors"]) >= PATTERN_SENSORS), None)
    z = inc()
    if sensors is not None and np.isfinite(relaxed) and relaxed > z:
        z += (relaxed - z) / 2
    while True:
        patterns: tuple = ()
        if sensors is not None:
            t0 = time.perf_counter()
            pattern, own = _dp_pattern.build(instance, objective, sensors, tab, z, stop, limits["threads"], search,
                                             tables)
            if own is not None and own.plan is not None:  # a plan of the subset above z is one of the whole
                offer(_subset_plan(instance, own.plan, sensors), f"pattern of {len(sensors)}")
            pattern_runs.append(dict(sensors=list(sensors), threshold=_external(tab, z), built=pattern is not None,
                                     labels=0 if own is None else own.labels, runtime_s=time.perf_counter() - t0))
            patterns = () if pattern is None else (pattern,)
        out = search(tab, max(z, inc()), progress=progress, patterns=patterns, **limits)
        passes.append(("bounded" if z <= inc() else "bounded above the midpoint", out))
        if not out.complete:  # the labels left open bound the plans above the pass's threshold
            out.open_bound = max(out.open_bound, z)
            return out, relaxed
        if out.plan is not None or z <= inc():
            return out, relaxed
        relaxed = min(relaxed, z)  # no plan beats z
        z = inc()


def _widening(beam_pass, beam: int, stop: Stop) -> None:
    """The incumbent's beam pass at ``beam`` labels per point, then wider ones with the cheap
    bound alone (as `--method beam`), doubling up to WIDEN * beam while the next is predicted
    (2.5 times the last pass) to take at most WIDEN_SHARE of the time left. They only add
    incumbents: n16-seed2026-001's best plan was 7.71 after beam 16 and a minute of dp, and
    is 9.86 after the cheap-bound pass of 64 (0.75 s), the bound 12.06."""
    t0 = time.perf_counter()
    beam_pass(beam)
    width = beam
    while width < WIDEN * beam and stop.check() is None:
        left = stop.remaining()
        if left is not None and 2.5 * (time.perf_counter() - t0) > WIDEN_SHARE * left:
            return
        width *= 2
        t0 = time.perf_counter()
        beam_pass(width, tdma=False)


def _pattern_tables(instance: Instance, objective: str, *, tour: bool = True,
                    pair_bytes: float = PAIR_TABLE_BYTES) -> Tables:
    """A subset's tables for its pattern's pass: the tour bound if ``tour``, the pairwise one
    if its table fits in ``pair_bytes`` (the bounds of the whole's bounded pass)."""
    tab = build_tables(instance, objective)
    if tour:
        tab.with_tour_bound()
    tab.with_pair_bound(pair_bytes)
    return tab


def _pair_room(stop: Stop, tab: Tables) -> float:
    """Bytes a pairwise table may take: PAIR_TABLE_BYTES, or less within the memory limit, with
    room left for the labels beside the tables already built."""
    return PAIR_TABLE_BYTES if stop.memory_bytes is None else min(PAIR_TABLE_BYTES, stop.memory_bytes - 2 * tab.nbytes)


def _subset_plan(instance: Instance, plan: tuple[np.ndarray, np.ndarray], sensors: list[int]) -> Plan:
    positions, schedule = plan
    return Plan.from_indices(instance, positions, np.array([sensors[u] if u >= 0 else -1 for u in schedule]))


def _greedy_plan(instance: Instance, objective: str, stop: Stop) -> Plan | None:
    """Greedy's plan as an incumbent, within the time left (its own stop rule follows ours)."""
    from voiopt.solvers.baselines import greedy

    left = stop.remaining()
    if left is not None and left <= 0:
        return None
    return greedy(instance, objective, time_limit=left, memory_limit=stop.memory_limit).plan
