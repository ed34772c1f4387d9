"""Exact label-setting dynamic programme with dominance and bounds (docs/dp.md).

A label is (slot, position, per-sensor rank of the latest upload, accumulated objective).
Forward over slots, at every (slot, position) only the non-dominated labels survive; labels
whose admissible bound cannot beat the incumbent are dropped; sensors that can no longer
change the objective are collapsed. The compiled kernels live in ``labels.kernels``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.plan import Plan
from voiopt.core.result import Result
from voiopt.core.simulate import simulate
from voiopt.errors import OptionError
from voiopt.runtime.status import Status
from voiopt.runtime.stop import TIME_LIMIT, Stop, Stopped, watch
from voiopt.solvers import options
from voiopt.solvers.base import (
    DEFAULT_MEMORY_GB,
    check_limits,
    check_threads,
    idle_plan,
    require_memory,
    warm_up_once,
)
from voiopt.solvers.dp import cover as covering
from voiopt.solvers.dp import patterns as pattern_bound
from voiopt.solvers.dp import subsets as subset_bound
from voiopt.solvers.labels.search import LABEL_BUDGET, SearchOutcome, search
from voiopt.solvers.labels.tables import (
    CHUNK_WORK,
    PAIR_TABLE_BYTES,
    Tables,
    build_tables,
    table_bytes,
)

__all__ = ["CHUNK_WORK", "PAIR_TABLE_BYTES", "Tables", "build_tables", "table_bytes", "search", "solve", "warm_up"]

DEFAULT_BEAM = 16
QUICK_BEAM = 2  # labels per point of the beam pass that gives the first incumbent
WIDEN = 4  # the incumbent's beam pass doubles its width up to WIDEN * beam,
WIDEN_SHARE = 0.1  # while the next pass is predicted (2.5 x the last) to take at most this share of the time left
FAST_BUDGET = 50_000  # labels of the first, unbounded pass before incumbents are computed
NEAR = 1e-9  # relative: a subset's passes run this far below their threshold (_below)
FUTURE_WORK = 1e9  # the most scans (pattern_bound.future_work) for the pattern of a subset's first pass: about 4 s
WHOLE_WORK = 5e9  # ... for the pattern of a subset's pass in the whole's bounded pass: about 20 s (_recorded)
SCANS_PER_S = 2e8  # the futures' scans a second, about (to predict their time)
WHOLE_SHARE = 0.3  # of the time left that the futures of that pattern may take, predicted
PATTERN_SENSORS = 3  # the bounded pass's pattern database: the first subset solved with this many sensors or more


def warm_up() -> float:
    """Compile (or load from numba's cache) the kernels once per process on a tiny instance, so
    that runtime_s measures the search alone; returns the seconds this took (0 once done)."""

    def load():
        from voiopt.networks.generate import generate

        tiny = generate(2, 4, width=2.0, height=2.0, seed=0, name="warm-up")
        for objective in objectives.OBJECTIVES:
            solve(tiny, objective, fast_budget=1)  # every pass and bound runs once
        # and a pattern database (its futures, then a pass it bounds): subsets of networks of 6
        # or more use them, within their share of the time
        mean = next(o for o in objectives.OBJECTIVES if subset_bound.applies(o, subset_bound.MIN_SENSORS))
        tab = build_tables(tiny, mean)
        pattern, _ = pattern_bound.build(tiny, mean, [0], tab, -np.inf, Stop(), 1, search,
                                       partial(_pattern_tables, objective=mean))
        search(tab, -np.inf, patterns=() if pattern is None else (pattern,))

    return warm_up_once("dp", load)


@dataclass(frozen=True)
class Options(options.Options):
    """dp's options (``solve``'s keywords)."""

    warm_start: Plan | None = None  # a first incumbent
    beam: int = DEFAULT_BEAM  # the incumbent beam pass's labels per point
    # the ingredients, each switched off only to measure it (docs/dp.md)
    greedy: bool = True  # the greedy incumbent
    collapse: bool = True  # a sensor that can no longer change the objective collapsed
    bounding: bool = True  # labels pruned by their bound against the incumbent
    tdma: bool = True  # bound 2: distinct ages (one upload a slot)
    pair_bound: bool = True  # bound 3: pairwise travel
    tour_bound: bool = True  # bound 4: the tour
    subsets: bool = True  # the bound of sensor subsets, solved first
    patterns: bool = True  # the subsets' pattern databases
    fast_budget: int = FAST_BUDGET  # labels of the first, unbounded pass before it is abandoned
    quick_beam: int = QUICK_BEAM  # the quick beam pass's labels per point
    threads: int = 1  # chunks of a slot expanded at once

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
        from voiopt.solvers.baselines.heuristics import stopped_result
        from voiopt.solvers.dp import fleet as fleet_dp

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
                              bounding=bounding, stopped=stopped_result)
    objective = objectives.get(objective)
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
           progress, threads, known: subset_bound.Known | None = None) -> Result:
    try:  # a subset's solve (known) must return a bound: its tables are built in full
        tab = build_tables(instance, objective, stop if known is None else None)
    except Stopped:  # stopped before any plan: the idle plan
        from voiopt.solvers.baselines.heuristics import stopped_result

        return stopped_result(instance, "dp", objective, stop, {"startup_s": startup_s},
                              "stopped while the value table was built (it grows as T^2)")
    if tour_bound and tdma and objectives.get(objective).per_slot:  # the bottleneck ones: slower, no tighter (docs/dp.md)
        tab.with_tour_bound()

    best_plan: Plan | None = None
    best_value = -np.inf  # internal (maximised) units
    incumbents: list[tuple[str, float]] = []

    def offer(plan: Plan, source: str) -> None:
        nonlocal best_plan, best_value
        v = tab.internal(simulate(instance, plan).metrics[objective])
        if best_plan is None or v > best_value:
            best_plan, best_value = plan, v
        incumbents.append((source, tab.external(v)))

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

    relaxed, subset_runs, kept = np.inf, [], []  # the subsets' (and cover) bound (internal units), records and passes
    cover = np.inf  # cover's bound, if computed
    pattern_runs: list[dict] = []
    if quick_beam > 0:  # a nearly free first incumbent: QUICK_BEAM labels per point
        beam_pass(quick_beam)
    # one thread: the label budget is checked after each chunk, and this pass is short
    layers = None if known is None or not patterns else []
    threshold = _below(inc(), known)
    out = search(tab, threshold, label_budget=fast_budget, progress=progress, record=layers,
                 **{**limits, "threads": 1})
    passes.append(("fast", out))
    if out.complete:
        _leave(known, layers, tab, threshold)
    else:
        plan = _greedy_plan(instance, objective, stop) if greedy and not stop.requested else None
        if plan is not None:
            offer(plan, "greedy")
        cover = covering.bound(instance, tab) if bounding and known is None else np.inf  # a subset's has its whole's
        relaxed = min(relaxed, cover)
        settled = subset_bound.reaches(best_value, relaxed)  # an incumbent attains the cover bound: proven
        if pair_bound and tdma and out.stopped == LABEL_BUDGET and not settled:
            tab.with_pair_bound(_pair_room(stop, tab))
        limits["tdma"] = tdma
        if beam > 0 and out.stopped == LABEL_BUDGET and not settled:
            _widening(beam_pass, beam, stop)
        if subsets and bounding and out.stopped == LABEL_BUDGET and not subset_bound.reaches(best_value, relaxed):
            def solve_subset(sub: Instance, seconds: float | None, labels: int | None, warm: Plan | None,
                             known: subset_bound.Known) -> Result:
                with watch(seconds, stop.memory_limit, labels) as sub_stop:
                    return _solve(sub, objective, sub_stop, 0.0, warm_start=warm, beam=DEFAULT_BEAM, greedy=True,
                                  collapse=True, bounding=True, tdma=True, pair_bound=True, tour_bound=True,
                                  subsets=False, patterns=patterns, fast_budget=FAST_BUDGET, quick_beam=QUICK_BEAM,
                                  progress=False, threads=threads, known=known)

            relaxed, subset_runs, kept = subset_bound.relax(instance, objective, tab, stop, offer, lambda: (best_plan, best_value),
                                        solve_subset, progress)
            relaxed = min(relaxed, cover)
        elif known is not None and bounding and out.stopped == LABEL_BUDGET:
            relaxed = min(relaxed, known.bound)  # a subset of this one's sensors bounds its optimum
        if out.stopped == LABEL_BUDGET and not subset_bound.reaches(best_value, relaxed):
            out, relaxed = _bounded(instance, objective, tab, stop, subset_runs or (known.runs if known else []), inc, relaxed,
                                    offer, passes, pattern_runs, progress, limits,
                                    partial(_pattern_tables, objective=objective, tour=tab.steps.shape[0] > 0,
                                            pair_bytes=_pair_room(stop, tab) if pair_bound and tdma else 0.0),
                                    patterns, known, kept)
    if out.plan is not None:
        plan = Plan.from_indices(instance, *out.plan)
        found = tab.internal(simulate(instance, plan).metrics[objective])
        incumbents.append(("dp", tab.external(found)))
        if best_plan is None or found > best_value:
            best_plan, best_value = plan, found
        else:  # the incumbent matches to rounding: keep it, count the DP value in the bound
            best_value = max(best_value, out.value)
    if best_plan is None:  # stopped before any plan
        offer(idle_plan(instance), "idle")
    if out.complete:
        bound_internal, status = max(best_value, out.value), Status.OPTIMAL
    elif subset_bound.reaches(best_value, relaxed):  # a plan as good as a subset's bound
        bound_internal, status = max(best_value, relaxed), Status.OPTIMAL
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
    if np.isfinite(relaxed) and (subset_runs or known is not None):  # with the cover bound, where lower
        solver["subset_bound"] = tab.external(relaxed)
    if np.isfinite(cover):
        solver["cover_bound"] = tab.external(cover)
    if subset_runs:
        solver["subsets"] = subset_runs
    if pattern_runs:
        solver["patterns"] = pattern_runs
    if status != Status.OPTIMAL:
        solver["stopped"] = stop.describe()
    return Result.from_plan(instance, "dp", objective, best_plan, status=status, bound=tab.external(bound_internal),
                            runtime_s=stop.elapsed(), solver=solver)


def _bounded(instance: Instance, objective: str, tab: Tables, stop: Stop, subset_runs: list[dict], inc, relaxed: float,
             offer, passes: list, pattern_runs: list, progress: bool, limits: dict,
             tables, patterns: bool = True, known: subset_bound.Known | None = None,
             kept: list = ()) -> tuple[SearchOutcome, float]:
    """The bounded pass, with the pattern database (``patterns``) of the first subset of at
    least PATTERN_SENSORS sensors that the subsets solved, if any (and ``patterns``). While the
    subsets' bound is above the incumbent, a first pass searches only above the midpoint z
    between them: it finds the optimum if that is above z (a pass is exact above its threshold)
    or proves the optimum at most z, and then the last pass starts from the incumbent. Returns
    the last pass and the bound proven (internal units); ``pattern_runs`` receives a record of
    each pattern built. ``tables(subset)`` compiles a subset with the bounds of the whole's
    bounded pass.

    A subset's solve (``known``, docs/dp.md "Subsets of the sensors") has no midpoint. Its first
    pass, if the smaller subset whose optimum bounds its own left a complete pass, searches just
    below that bound with the pattern of that pass: it finds a plan attaining the bound (often:
    the sensor that joined does not lower the optimum) or proves the optimum below it. Its
    passes run a hair (NEAR) below their threshold and are recorded, for the next subset."""
    solved = [r for r in subset_runs if r["status"] == Status.OPTIMAL and len(r["sensors"]) >= PATTERN_SENSORS]
    sensors = solved[0]["sensors"] if solved and patterns else None
    z = inc()
    given = extra = None  # a smaller subset's pass, for a subset's first pass; a subset's pass, for the whole's passes
    if known is not None:
        rec = known.recorded
        # just below B; or at the recorded pass's own threshold, where B came back from the
        # objective's units an ulp lower (a pattern serves only passes at or above its threshold)
        near = -np.inf if rec is None else max(_below(relaxed, known), rec.threshold)
        if patterns and z < near < relaxed:
            given = _pattern_of(rec, known.sensors, tab, stop, limits["threads"], pattern_runs)
            z = near if given is not None else z
    else:
        if sensors is not None and np.isfinite(relaxed) and np.isfinite(z) and relaxed > z:  # z: no incumbent
            z += (relaxed - z) / 2
        chosen = _recorded(kept, z, relaxed, stop) if patterns else None
        if kept:  # free the other subsets' passes: the memory limit does not count them
            kept.clear()
        if chosen is not None:  # the pattern of a subset's own pass, beside the pattern of 3 (docs/dp.md)
            extra = _pattern_of(chosen[1], chosen[0], tab, stop, limits["threads"], pattern_runs)
    def level() -> float:  # the pass's threshold (a subset's a hair below; its first pass is below B already)
        return max(z, inc()) if given is not None else _below(max(z, inc()), known)

    while True:
        found: tuple = ()
        at = level()
        if given is not None:
            found = (given,)
        elif sensors is not None:  # built at the pass's threshold: a pattern serves passes at or above its own
            t0 = time.perf_counter()
            pattern, own = pattern_bound.build(instance, objective, sensors, tab, at, stop, limits["threads"], search,
                                             tables)
            if own is not None and own.plan is not None:  # a plan of the subset above z is one of the whole
                offer(_subset_plan(instance, own.plan, sensors), f"pattern of {len(sensors)}")
            pattern_runs.append(dict(sensors=list(sensors), threshold=tab.external(at), built=pattern is not None,
                                     recorded=False, labels=0 if own is None else own.labels,
                                     runtime_s=time.perf_counter() - t0))
            found = () if pattern is None else (pattern,)
        if extra is not None and extra.threshold <= at:
            found += (extra,)
        threshold = max(at, level())  # the pattern's offer may have raised the incumbent
        layers = None if known is None or not patterns else []
        out = search(tab, threshold, progress=progress, patterns=found, record=layers, **limits)
        passes.append(("bounded" if z <= inc() else "bounded near the bound" if given else "bounded above the midpoint",
                       out))
        if not out.complete:  # the labels left open bound the plans above the pass's threshold
            out.open_bound = max(out.open_bound, z)
            return out, relaxed
        _leave(known, layers, tab, threshold)
        if out.plan is not None or z <= inc():
            return out, relaxed
        relaxed = min(relaxed, z)  # no plan beats z
        z, given = inc(), None


def _leave(known: subset_bound.Known | None, layers: list | None, tab: Tables, threshold: float) -> None:
    """A subset's complete pass, left for the next subset (``known.made``) if the futures of its
    pattern take at most FUTURE_WORK scans: the first pass of a subset of 8 of a network of 16
    waited 34 s for the pattern of a pass of 349k labels (docs/dp.md); and for the whole's
    bounded pass (``known.kept``, ``_recorded``) if they take at most WHOLE_WORK."""
    if known is None:
        return
    known.made = known.kept = None
    work = np.inf if layers is None else pattern_bound.future_work(layers, tab)
    if work <= WHOLE_WORK:  # without the bounds' tables
        light = replace(tab, best_rank=tab.best_rank[:0], point_steps=tab.point_steps[:0], pair=tab.pair[:0])
        known.kept = pattern_bound.Recorded(layers, light, threshold, work)
        known.made = known.kept if work <= FUTURE_WORK else None


def _pattern_of(rec: pattern_bound.Recorded, sensors: list[int], tab: Tables, stop: Stop, threads: int,
                pattern_runs: list) -> pattern_bound.Pattern | None:
    """The pattern database of a subset's recorded pass (``sensors``: its sensors among those of
    ``tab``), or None if its futures were stopped or its ranks differ; its record (no labels: the
    pass was counted in its subset) goes to ``pattern_runs``."""
    t0 = time.perf_counter()
    own = pattern_bound.from_layers(rec.layers, rec.tab, rec.threshold, stop, threads)
    pattern = None if own is None else own.within(sensors, tab)
    pattern_runs.append(dict(sensors=list(sensors), threshold=tab.external(rec.threshold), built=pattern is not None,
                             recorded=True, labels=0, runtime_s=time.perf_counter() - t0))
    return pattern


def _recorded(kept, first: float, relaxed: float, stop: Stop) -> tuple | None:
    """Of the complete passes the subsets left (their sensors, ``pattern_bound.Recorded``), the one
    whose pattern joins the whole's bounded passes: that of the most sensors among those run at
    most at the first pass's threshold ``first`` (a pattern serves only passes at or above its
    own; a subset's pass runs at the subset's incumbent, often above the whole's optimum) and
    below the subsets' bound ``relaxed``, whose futures are predicted to take at most
    WHOLE_SHARE of the time left. A subset's own pass bounds far more tightly than the pattern
    of PATTERN_SENSORS sensors: docs/dp.md, "The pattern of a subset's own pass"."""
    left = stop.remaining()
    fits = [(keep, rec) for keep, rec in kept
            if rec.threshold <= first and rec.threshold < relaxed
            and (left is None or rec.work / SCANS_PER_S <= WHOLE_SHARE * left)]
    return max(fits, key=lambda kr: len(kr[0]), default=None)


def _below(value: float, known: subset_bound.Known | None) -> float:
    """A subset's pass threshold a hair (NEAR) below ``value``, so that the pattern of the pass
    serves the next subset's first pass, just below the same bound; the whole's is ``value``."""
    return value - NEAR * abs(value) if known is not None and np.isfinite(value) else value


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
    from voiopt.solvers.baselines.heuristics import greedy

    left = stop.remaining()
    if left is not None and left <= 0:
        return None
    return greedy(instance, objective, time_limit=left, memory_limit=stop.memory_limit).plan
