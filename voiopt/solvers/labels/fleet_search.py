"""The label-setting search over two robots' product state (MODEL.md section 10): both robots'
points and moves left, and the per-sensor ranks of the one-robot tables (``tables``). One
kernel (``fleet_kernels.expand``) serves the pass without uploads (a legal joint plan, or the
proof that none exists: ``legal_pass``), a beam pass and the full pass with bounds and
dominance. dp for two robots (``solvers.dp.fleet``) and the fleet walker's exact fallback
(``solvers.baselines.fleet``) both search with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from voiopt.core.instance import Instance
from voiopt.errors import MemoryLimitError, OptionError
from voiopt.grid import lattice as lattice_mod
from voiopt.runtime.progress import progress_bar
from voiopt.runtime.stop import GB, INTERRUPTED, MEMORY_LIMIT, Interrupted, Stop, watch
from voiopt.solvers.base import (
    DP_MAX_ROBOTS,
)
from voiopt.solvers.labels.tables import (
    CHUNK_WORK,
    Tables,
    build_tables,
    run_of,
    table_bytes,
    watched,
)

MAX_ROBOTS = DP_MAX_ROBOTS  # the product state of three robots on any useful grid is out of reach
FLEET_BEAM = 2  # labels per point pair in the incumbent's beam pass: wider costs more than it saves (docs/dp.md)
LABEL_BYTES = 32  # a label kept for the parent pointers: parent 8, two uploads 4, two points 8, moves left 4, slack
CANDIDATE_BYTES = 200  # a child in the kernel's buffers, besides its ranks (twice): key, values, record, output
LIVE_BYTES = 24  # more per label of the live layer: acc 8, bound 8, and the offsets, besides its ranks


@dataclass
class Joint:
    """The two robots' parts of the product state, beside the network's Tables."""

    tab: Tables
    starts: tuple[int, int]
    budgets: tuple[int, int]
    to_end: tuple[np.ndarray, np.ndarray]
    n: int


def joint_states(instance: Instance) -> float:
    """The states of the product (slot, p0, p1, moves used by each robot whose budget binds):
    an upper bound on the labels of one per state, from the sizes alone."""
    T = instance.horizon
    free = lattice_mod.n_points(instance) - len(instance.blocked)
    states = float(T) * free * (free - 1)
    for r in instance.robots:
        if r.max_moves is not None and r.max_moves < T - 1:
            states *= r.max_moves + 1
    return states


def joint_bytes(instance: Instance) -> float:
    """Bytes of the product state at one label a state, with the network's tables."""
    N = instance.n_sensors
    per_slot = joint_states(instance) / instance.horizon
    return table_bytes(instance) + joint_states(instance) * LABEL_BYTES + 2 * per_slot * (2 * N + LIVE_BYTES)


def check_fleet(instance: Instance, memory_limit: float | None) -> None:
    """Decline, in one line, what the joint programme cannot hold."""
    K = instance.n_robots
    if K > MAX_ROBOTS:
        raise OptionError(f"method: dp plans jointly for at most {MAX_ROBOTS} robots (the instance has {K}); use milp")
    need = joint_bytes(instance)
    if memory_limit is not None and need > memory_limit * GB:
        free = lattice_mod.n_points(instance) - len(instance.blocked)
        raise OptionError(f"dp: the joint state of {K} robots on {free} points over {instance.horizon} slots "
                          f"needs about {need / GB:.3g} GB, over --memory-limit {memory_limit:g}; use milp")


def build_joint(instance: Instance, objective: str, stop: Stop | None = None) -> Joint:
    """The joint tables; voiopt.runtime.stop.Stopped if ``stop`` says stop while W is built (it grows as
    T^2: 35 s at T = 1633, past a 1.69 s limit, a fuzz campaign)."""
    tab = build_tables(instance.robot(0), objective, stop)  # ranks and worths are the network's, not a robot's
    # to_end as a fresh writable copy whether or not the robot has an end: one array type, so
    # the kernels compile once (a read-only array is another numba type: a compile in the search)
    lats = [lattice_mod.build(instance.robot(k)) for k in range(2)]
    return Joint(tab, (lats[0].start, lats[1].start), (lats[0].budget, lats[1].budget),
                 tuple(np.array(lat.to_end, dtype=np.int64) for lat in lats), lats[0].n_points)


@dataclass
class Pass:
    value: float  # internal; -inf if no plan beat the incumbent
    plan: tuple[np.ndarray, np.ndarray] | None  # (K, T) points and schedule
    complete: bool
    open_bound: float  # when incomplete: the largest bound of a label still open
    labels: int = 0
    generated: int = 0
    peak_layer: int = 0
    peak_bytes: int = 0
    slots_done: int = 0

    def summary(self) -> dict:
        return dict(labels=self.labels, children_generated=self.generated, peak_layer_labels=self.peak_layer,
                    slots_done=self.slots_done, complete=self.complete)


def search(jt: Joint, incumbent: float, stop: Stop, *, beam: int = 0, uploads: bool = True,
           progress: bool = False) -> Pass:
    """One forward pass over slots; stops incomplete when the stop rule says so."""
    from voiopt.solvers.labels import fleet_kernels as core

    tab, n = jt.tab, jt.n
    T, _, N = tab.up_rank.shape
    ranks = tab.initial_rank[None, :].copy()
    acc = np.array([np.inf if tab.mode != core.SUM else 0.0])
    pos0, pos1 = np.array([jt.starts[0]], np.int32), np.array([jt.starts[1]], np.int32)
    left0, left1 = np.array([jt.budgets[0]], np.int16), np.array([jt.budgets[1]], np.int16)
    ub = np.array([np.inf])
    history: list[tuple] = []
    out = Pass(-np.inf, None, True, -np.inf, labels=1, peak_layer=1)
    stored = 0
    n_up = tab.in_range_count if uploads else np.zeros(n, np.int64)
    per_point = 1 + n_up
    with progress_bar(progress) as bar:
        task = bar.add_task("dp pairs", total=T)
        for t in range(T - 1):
            keep = ub > incumbent
            bucket = pos0.astype(np.int64) * n + pos1
            off = np.concatenate([[0], np.cumsum(np.bincount(bucket[keep], minlength=n * n))])
            idx = np.flatnonzero(keep)  # labels are grouped by bucket already
            work = _work(jt, off, per_point)
            layer = (ranks[idx], acc[idx], ub[idx], left0[idx], left1[idx])
            parts = []
            b_lo = 0
            while b_lo < n * n:
                used = tab.nbytes + stored + 2 * ranks.nbytes + sum(p[0].nbytes + p[1].nbytes + p[2].nbytes for p in parts)
                room = np.inf if stop.memory_bytes is None else (stop.memory_bytes - used) / (CANDIDATE_BYTES + 4 * N)
                b_hi, total = run_of(work, b_lo, min(CHUNK_WORK, room))
                if total > room:  # one bucket's children alone would pass the memory limit: stop before allocating
                    stop.request(MEMORY_LIMIT)
                    return _incomplete(out, ub, keep, t)
                part = watched(stop, core.expand, tab.mode, t, *layer, off, tab.neighbors, tab.up_rank, tab.in_range_list, tab.in_range_count, tab.W,
                                tab.best_rank, jt.to_end[0], jt.to_end[1], incumbent, b_lo, b_hi, beam, uploads)
                if part[5] or stop.check(used + sum(a.nbytes for a in part[:3])):
                    return _incomplete(out, ub, keep, t)
                parts.append(part[:3])
                out.generated += int(part[4])
                b_lo = b_hi
            ranks = np.concatenate([p[0] for p in parts])
            acc, ub = np.concatenate([p[1] for p in parts]).T
            rec = np.concatenate([p[2] for p in parts])
            parent, up0, up1 = idx[rec[:, 0]], rec[:, 1].astype(np.int16), rec[:, 2].astype(np.int16)
            pos0, pos1 = rec[:, 3].astype(np.int32), rec[:, 4].astype(np.int32)
            left0, left1 = rec[:, 5].astype(np.int16), rec[:, 6].astype(np.int16)
            history.append((parent, up0, up1, pos0, pos1))
            stored += sum(a.nbytes for a in history[-1])
            out.labels += len(acc)
            out.peak_layer = max(out.peak_layer, len(acc))
            out.peak_bytes = max(out.peak_bytes, stored + ranks.nbytes + acc.nbytes + ub.nbytes)
            out.slots_done = t + 1
            bar.update(task, advance=1, description=f"dp pairs  {len(acc):,} labels")
            if len(acc) == 0:
                return out
        keep = np.flatnonzero(ub > incumbent)
        value, l, u0, u1 = core.finish(tab.mode, ranks[keep], acc[keep], pos0[keep], pos1[keep], tab.up_rank,
                                       tab.in_range_list, tab.in_range_count, tab.W, uploads)
        bar.update(task, advance=1)
    out.slots_done = T
    if l < 0 or value <= incumbent:
        return out
    points = np.empty((2, T), np.int64)
    schedule = np.full((2, T), -1, np.int64)
    schedule[:, T - 1] = (u0, u1)
    label = int(keep[l])
    for t in range(T - 1, 0, -1):
        parent, up0, up1, at0, at1 = history[t - 1]
        points[:, t] = (at0[label], at1[label])
        schedule[:, t - 1] = (up0[label], up1[label])
        label = int(parent[label])
    points[:, 0] = jt.starts
    out.value, out.plan = float(value), (points, schedule)
    return out


def _work(jt: Joint, off: np.ndarray, per_point: np.ndarray) -> np.ndarray:
    """(label, upload pair) children per target bucket: the chunks' sizes."""
    n, nbr = jt.n, jt.tab.neighbors
    count = (off[1:] - off[:-1]).reshape(n, n) * per_point[:, None] * per_point[None, :]
    into = np.zeros((n, n), dtype=np.int64)
    for k0 in range(5):
        a = nbr[:, k0]
        for k1 in range(5):
            b = nbr[:, k1]
            into += np.where((a >= 0)[:, None] & (b >= 0)[None, :], count[np.ix_(np.maximum(a, 0), np.maximum(b, 0))], 0)
    return into.ravel()


def _incomplete(out: Pass, ub: np.ndarray, keep: np.ndarray, t: int) -> Pass:
    """Every completion that beats the incumbent passes through an open label of slot t (or
    one dominating a dropped label), so the largest open bound bounds the optimum."""
    out.complete = False
    out.open_bound = float(ub[keep].max()) if keep.any() else -np.inf
    out.slots_done = t
    return out


def legal_pass(jt: Joint, stop: Stop, limited: bool = False) -> Pass:
    """A legal joint plan, or the proof that none exists: the pass without uploads, whose labels
    are at most one per (slot, point pair, moves left) state. ``limited``: the pass follows
    ``stop`` like any other, and a stop before a plan leaves ``plan`` None and ``complete``
    False (the caller has another plan to return: dp, greedy's). Otherwise a stop must return
    a plan, so this pass alone runs past the time limit (it is small: 30,000 labels, 0.35 s, on
    6 x 6 points at T = 30, but 37 s on a 21 x 21 factory floor at T = 131); Ctrl-C and the
    memory limit still end it, as errors: there is no plan to return."""
    if limited:
        return search(jt, -np.inf, stop, uploads=False)
    with watch(None, stop.memory_limit) as own:
        out = search(jt, -np.inf, own, uploads=False)
    if own.reason == INTERRUPTED:
        stop.request(INTERRUPTED, own.signal)
        raise Interrupted(own.signal)
    if own.reason is not None:
        raise MemoryLimitError(f"--memory-limit: dp for two robots found no legal joint plan within "
                               f"{stop.memory_limit:g} GB (raise --memory-limit, or make the instance smaller)")
    return out
