"""The subset relaxation of dp (docs/dp.md, "Subsets of the sensors").

Dropping sensors from a network can only raise every slot's minimum worth, and every plan of
the network is a plan of the smaller one (same lattice, robot, slots and rules; uploads of a
dropped sensor become idle slots, which lowers no worth of the others). So the optimum (or a
proven bound) of the network restricted to any subset S of its sensors bounds the optimum of
the whole, and the subset's plan is a legal plan of the whole. Where a few sensors decay much
faster than the rest (rho ~ U(0, 1), the paper's networks), they set the minimum in almost
every slot, and a subset of 4 to 8 of them, solved exactly in seconds, bounds networks of 12
or 16 sensors within a fraction of a percent, or proves their optimum.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.plan import Plan
from voiopt.core.simulate import simulate
from voiopt.objectives import Worth
from voiopt.runtime.progress import progress_bar
from voiopt.runtime.status import Status
from voiopt.runtime.stop import Stop
from voiopt.solvers.labels.tables import progress_text

SHARE = 0.3  # of the time left that the subsets may take (the pattern databases need little of it)
STRETCH = 0.5  # of the time left: the most they may take when the next subset is predicted to fit in it
LEFT_OUT = 4  # sensors left out of the next subset from which it may take FAR without a prediction
FAR = 0.9  # of the time left: the most they may take then (the bounded pass is not expected to finish)
LABELS = 1_000_000  # their budget when there is no time limit (about 10 s): labels, so that such a run is deterministic
FIRST = 2  # sensors of the first subset
MIN_SENSORS = 6  # with fewer, a subset is about as hard as the whole (the lattice and T dominate)


@dataclass
class Known:
    """What the subsets solved so far tell the solve of a larger one, in its own sensors'
    indices: the least of their bounds (internal units; it bounds the larger one's optimum too),
    their records (``relax``), and the last complete pass of the last subset of that bound
    (``_dp_pattern.Recorded``, from which a pattern database is made), with that subset's
    sensors. The solve leaves its own last complete pass in ``made`` if its pattern is cheap
    enough for the next subset, and in ``kept`` if it is for the whole (``dp._recorded``)."""

    bound: float
    runs: list[dict]
    recorded: object = None
    sensors: list[int] = field(default_factory=list)
    made: object = None
    kept: object = None


def applies(objective: str, n_sensors: int) -> bool:
    """The subsets run for `mean-min-voi` with MIN_SENSORS or more. Its minimum is set by the
    few sensors that decay fastest; AoI ages alike in every sensor, and the bottleneck
    objectives are proven by the full search (factory floor, N = 12, T = 100: `min-voi` proven
    in 44 s without the subsets, not in 60 s with them; `mean-max-aoi` the same bound either
    way)."""
    spec = objectives.get(objective)
    return spec.per_slot and spec.worth == Worth.VOI and n_sensors >= MIN_SENSORS


def until(spent: float, budget: float, cap: float, times: list[float], left_out: int = 0,
          far: float = 0.0) -> float:
    """Until when (seconds since the subsets began) the next subset may run: ``far`` when it
    leaves ``left_out`` >= LEFT_OUT sensors of the whole out; else ``cap`` when the subsets
    solved so far (``times``, seconds each) predict that the next one finishes within it (its
    time: the last one's, times the last ratio of two, at least 1); else the share's ``budget``.
    Without this a subset about to finish was cut at the share and its time wasted: a 60 s run
    then failed networks that a 300 s run proves in 14 to 21 s (docs/dp.md). The prediction is
    often wrong by 2x either way. With LEFT_OUT sensors or more beyond the next subset, the
    bounded pass over the whole, which the share keeps time for, has proven no network in the
    rest of a minute in any run measured (it proves networks whose subsets stopped 1 to 3
    sensors short of the whole), so the subsets are the only way to a proof there."""
    if far > budget and left_out >= LEFT_OUT:
        return far
    if len(times) >= 2 and cap > budget:
        predicted = times[-1] * max(times[-1] / max(times[-2], 1e-3), 1.0)
        if spent + predicted <= cap:
            return cap
    return budget


def need_order(tab) -> list[int]:
    """Sensors by how low the per-sensor relaxation keeps their worth from the start (bound 1
    summed over slots; its minimum for a bottleneck objective): those most likely to set the
    minimum come first."""
    from voiopt.solvers.labels import kernels as core

    N, T = tab.W.shape[0], tab.W.shape[2] - 1
    rank = np.maximum(tab.initial_rank[:, None], tab.best_rank[:, tab.start, 0, 1:])  # (N, T): slots 1..T
    hi = tab.W[np.arange(N)[:, None], rank, np.arange(1, T + 1)[None, :]]
    score = hi.sum(axis=1) if tab.mode == core.SUM else hi.min(axis=1)
    return [int(i) for i in np.argsort(score, kind="stable")]


def relax(instance: Instance, objective: str, tab, stop: Stop, offer, incumbent, solve,
          progress: bool = False) -> tuple[float, list[dict], list[tuple[list[int], object]]]:
    """The smallest bound (internal units) over a growing subset of the sensors, each subset
    solved by ``solve(subset, seconds, labels, warm_start, known)`` (dp; ``Known``) within the
    subsets' budget (+inf if none finished in it), and one record per subset solved: its
    sensors, status, seconds, labels, bound (the objective's units) and the names of its
    passes, for ``solver.subsets``; and the complete passes the subsets left for the whole
    (``Known.kept``: the last of each subset that left one), with their sensors.

    The subset starts with the sensors that ``need_order`` puts first. dp solves it from the
    best plan so far (``incumbent()``: plan or None, and its internal value) restricted to it,
    and from what the smaller subsets tell it (``Known``); its plan is offered to ``offer`` as
    an incumbent and simulated on the whole network, and the sensor outside the subset whose
    worth falls furthest below the subset's minimum (summed over slots) joins it. This ends when
    none does (the plan is then optimal for the whole), when the best plan attains the bound,
    when the budget is spent (``until``) or a subset is not solved. Without a time limit the
    budget is LABELS labels, not seconds: the same run then takes the same subsets, passes and
    plan however busy the machine is.
    ``progress`` shows each subset with the best value, the bound and the gap."""
    N = instance.n_sensors
    if not applies(objective, N):
        return np.inf, [], []
    left = stop.remaining()
    if left is not None:
        budget, cap, far = (share * max(left, 0.0) for share in (SHARE, STRETCH, FAR))
    t0 = time.perf_counter()
    keep = sorted(need_order(tab)[:FIRST])
    best = np.inf
    tight: tuple = (None, [])  # the last complete pass of the last subset of the least bound, and its sensors
    records: list[dict] = []
    kept: list[tuple[list[int], object]] = []
    with progress_bar(progress) as bar:
        task = bar.add_task("dp subsets", total=None)
        while len(keep) < N:
            if left is None:
                seconds, labels = None, LABELS - sum(rec["labels"] for rec in records)
            else:
                spent = time.perf_counter() - t0
                end = until(spent, budget, cap, [rec["runtime_s"] for rec in records], N - len(keep), far)
                seconds, labels = end - spent, None
            if (labels if seconds is None else seconds) <= 0 or stop.check() is not None:
                break
            bar.update(task, description=f"dp subset of {len(keep)} sensors{_line(tab, incumbent()[1], best)}")
            sub = restricted(instance, keep, f"{instance.name}-subset{len(keep)}")
            known = Known(best, [dict(rec, sensors=[keep.index(i) for i in rec["sensors"]]) for rec in records],
                          tight[0], [keep.index(i) for i in tight[1]])
            r = solve(sub, seconds, labels, _restricted(incumbent()[0], keep), known)
            bound = tab.internal(r.bound)
            if bound < best:
                tight = (None, [])  # a pass of a larger bound ran at too high a threshold
            best = min(best, bound)
            if known.made is not None and bound <= best:
                tight = (known.made, list(keep))
            if known.kept is not None:
                kept.append((list(keep), known.kept))
            records.append(dict(sensors=list(keep), status=r.status, runtime_s=r.runtime_s,
                                labels=r.solver["labels"], bound=r.bound, passes=list(r.solver["passes"])))
            plan = Plan(r.plan.positions, tuple(None if u is None else keep[u] for u in r.plan.schedule))
            offer(plan, f"subset of {len(keep)}")
            if r.status != Status.OPTIMAL or reaches(incumbent()[1], best):
                break  # a larger subset would take longer still, or the bound is attained
            joins = _furthest_below(instance, objective, plan, keep)
            if joins is None:
                break  # no other sensor sets a minimum: the subset's plan is optimal for the whole
            keep = sorted([*keep, joins])
    return best, records, kept


def restricted(instance: Instance, keep: list[int], name: str) -> Instance:
    """The network of the sensors ``keep`` alone (same lattice, robot, slots and rules)."""
    sensors = instance.to_dict()["sensors"]
    return instance.replace(sensors=[sensors[i] for i in keep], name=name)


def reaches(value: float, bound: float) -> bool:
    """The plan's value equals the bound, up to the rounding of two sums of the same terms."""
    return bool(np.isfinite(bound) and value >= bound - 1e-12 * abs(bound))


def _furthest_below(instance: Instance, objective: str, plan: Plan, keep: list[int]) -> int | None:
    """The sensor outside ``keep`` whose worth under ``plan`` falls furthest below the minimum
    over ``keep`` (summed over slots 1..T), or None if none falls below it."""
    sim = simulate(instance, plan)
    aoi = objectives.get(objective).worth == Worth.AOI
    worth = -np.asarray(sim.aoi, dtype=float)[1:] if aoi else np.asarray(sim.voi)[1:]
    below = np.clip(worth[:, keep].min(axis=1)[:, None] - worth, 0.0, None).sum(axis=0)
    below[keep] = 0.0
    return int(np.argmax(below)) if below.any() else None


def _line(tab, value: float, bound: float) -> str:
    """Best value, bound and gap in the objective's units, for the progress bar."""
    if not (np.isfinite(value) and np.isfinite(bound)):
        return ""
    return progress_text(tab.external(value), tab.external(bound))


def _restricted(plan: Plan | None, keep: list[int]) -> Plan | None:
    """The plan with the uploads of sensors outside ``keep`` left out, renumbered for the subset."""
    if plan is None:
        return None
    index = {i: k for k, i in enumerate(keep)}
    return Plan(plan.positions, tuple(index.get(u) if u is not None else None for u in plan.schedule))
