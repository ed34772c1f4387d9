"""One forward pass of dp over the slots (docs/dp.md, "State and transitions" to "Bounds"):
the labels of each slot expanded by the compiled kernels of ``labels.kernels``, chunk by chunk,
filtered by dominance and by the bounds (and pattern databases) against an incumbent, with
the stop rule, memory and a label budget checked between chunks. ``dp`` runs its passes
(beam, fast, bounded) through ``search``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from voiopt.runtime.progress import progress_bar
from voiopt.runtime.stop import Stop
from voiopt.solvers.labels.tables import CHUNK_WORK, Tables, progress_text, run_of, watched_all


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
    each thread about four to do, but none below CHUNK_WORK / 16: a tiny layer cut into
    4 x threads calls costs more in calls and threads than it saves (a beam of 2 on N = 6,
    T = 30 took 64 ms on two threads against 28 ms on one)."""
    size = CHUNK_WORK if threads == 1 else min(CHUNK_WORK, max(CHUNK_WORK // 16, int(work.sum()) // (4 * threads)))
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
    from voiopt.solvers.labels import kernels as core

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
            stop.spend(len(acc))  # at a layer's end only: where an allowance stops a pass is the same for any threads
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
    return progress_text(tab.external(inc), tab.external(bound))



def _incomplete(ub, keep, labels, generated, peak_layer, peak_bytes, t, stopped) -> SearchOutcome:
    open_bound = float(ub[keep].max()) if keep.any() else -np.inf
    return SearchOutcome(-np.inf, None, False, open_bound, labels, generated, peak_layer, peak_bytes, t, stopped)


LABEL_BUDGET = "label budget"  # a pass's own budget, not a stop of the solve


def _must_stop(stop: Stop, used: float, label_budget, labels) -> str | None:
    reason = stop.check(used)
    if reason is None and label_budget is not None and labels > label_budget:
        return LABEL_BUDGET
    return reason
