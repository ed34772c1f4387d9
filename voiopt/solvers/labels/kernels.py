"""Compiled kernels of the label-setting dynamic programme (see voiopt/solvers/dp/solver.py, docs/dp.md).

Everything here works in "maximise" form on integer per-sensor ranks:

- ``rank[i]``: the rank of sensor i's latest upload among all its candidate uploads, sorted
  by score (MODEL.md section 4), so a larger rank is better at every later slot. The largest
  rank index ``W.shape[1] - 1`` means "collapsed": the sensor can no longer change the
  objective, and its value table row is +inf.
- ``W[i, r, t]``: what sensor i contributes in slot t with rank r (V_i(t), or -A_i(t) for the
  AoI objectives); the slot term is min_i W[i, rank_i, t].
- ``mode``: 0 accumulates the slot terms by sum (the mean objectives), 1 by min (the bottleneck
  objectives).
- ``best_rank[i, p, t, t2]``: the best rank sensor i alone could have in slot t2 through an
  upload in slots t..t2-1 by an entity standing at p in slot t (-1 if none is reachable): the
  per-sensor relaxation behind the admissible future bound.
- ``point_steps[i, j, p]``: the fewest moves between sensor i's j-th in-range point and point
  p, around blocked points (Manhattan on an open lattice). The bounds use these exact
  distances; any smaller number would still give a bound, only a weaker one.
- ``left[l]``: the moves label l may still make (MODEL.md section 9), capped at the slots
  left; with a budget it is one more lane of the dominance test (more is better), and
  ``to_end[q]`` prunes children that could no longer reach ``end`` in time and budget.
"""

from __future__ import annotations

import numpy as np

from voiopt.runtime.jit import njit
from voiopt.solvers.labels.bounds import distinct_ages_bound, pair_bound, tour_bound

SUM, MIN = 0, 1


@njit(cache=True)
def best_rank_table(up_rank, point_steps, sensor_points, sensor_point_count):
    """best_rank[i, p, t, t2] for t2 in t+1..T (other entries -1), int16."""
    T, n, N = up_rank.shape
    out = np.full((N, n, T, T + 1), -1, dtype=np.int16)
    for i in range(N):
        for p in range(n):
            # steps from p to each in-range point of sensor i
            k = sensor_point_count[i]
            steps = np.empty(k, dtype=np.int64)
            for j in range(k):
                steps[j] = point_steps[i, j, p]
            for t in range(T):
                cur = -1
                for s in range(t, T):
                    for j in range(k):
                        if steps[j] <= s - t:
                            r = up_rank[s, sensor_points[i, j], i]
                            if r > cur:
                                cur = r
                    out[i, p, t, s + 1] = cur
    return out


@njit(cache=True, inline="always")
def combine(mode, acc, w):
    if mode == SUM:
        return acc + w
    return min(acc, w)


@njit(cache=True, inline="always")
def _child(mode, rank, acc, u, up_rank_here, W, tau, child):
    """The ranks after uploading sensor u (-1: none) into ``child``; returns the new accumulated value."""
    N = rank.shape[0]
    for i in range(N):
        child[i] = rank[i]
    if u >= 0:
        child[u] = up_rank_here[u]
    w = np.inf
    for i in range(N):
        v = W[i, child[i], tau]
        if v < w:
            w = v
    return combine(mode, acc, w)


LANE_HIGH = np.uint64(0x8000800080008000)


@njit(cache=True, inline="always")
def _ranks_geq(a, b):
    """Every 16-bit lane of a >= that of b (lanes < 2**15): no borrow crosses a lane."""
    for w in range(a.shape[0]):
        if ((a[w] | LANE_HIGH) - b[w]) & LANE_HIGH != LANE_HIGH:
            return False
    return True


DIMS = 3  # lanes whose values file the kept candidates of the Pareto filter,
BINS = 8  # in this many cells each
SMALL = 64  # candidates of a point up to which the filter scans the kept ones without the grid


@njit(cache=True, inline="always")
def _lane(key, d):
    """Lane d (16 bits) of a packed key."""
    return np.int64((key[d // 4] >> np.uint64(16 * (d % 4))) & np.uint64(0xFFFF))


@njit(cache=True, nogil=True)
def pareto(key, neg_acc, neg_sum, m, lanes, kept, halt):
    """The non-dominated candidates 0..m-1 of one point into kept[:nk]; returns nk (-1 if
    halted). Ordered by accumulated value, then lane sum (both descending), then generation
    order, a candidate can only be dominated by one before it: one with a value at least as
    high and each of the ``lanes`` lanes of its ``key`` at least as high (of identical ones the
    first is kept).

    The kept candidates are filed on a grid over the DIMS lanes whose values spread most, BINS
    cells each way (monotone in the value): only the cells at or above a candidate's along each
    can hold one that dominates it. The one that dominated last is tried first: dominators come
    in runs. Which candidates are kept, and in which order, does not depend on the grid. Up to
    SMALL candidates the kept ones are scanned newest first without it."""
    o1 = np.argsort(neg_sum[:m], kind="mergesort")
    order = o1[np.argsort(neg_acc[o1], kind="mergesort")]
    if m <= SMALL:  # a small front: every kept candidate, newest first, costs less than the grid
        nk = 0
        for j, c in enumerate(order):
            if (j & 255) == 0 and halt[0]:
                return -1
            free = True
            for h in range(nk - 1, -1, -1):
                if _ranks_geq(key[kept[h]], key[c]):
                    free = False
                    break
            if free:
                kept[nk] = c
                nk += 1
        return nk
    dim = np.full(DIMS, -1, dtype=np.int64)
    lo = np.zeros(DIMS, dtype=np.int64)
    spread = np.zeros(DIMS, dtype=np.int64)
    for d in range(lanes):
        lo_d = _lane(key[0], d)
        hi_d = lo_d
        for h in range(1, m):
            v = _lane(key[h], d)
            if v < lo_d:
                lo_d = v
            elif v > hi_d:
                hi_d = v
        for e in range(DIMS):  # the DIMS widest spreads, widest first
            if hi_d - lo_d > spread[e]:
                for f in range(DIMS - 1, e, -1):
                    dim[f], lo[f], spread[f] = dim[f - 1], lo[f - 1], spread[f - 1]
                dim[e], lo[e], spread[e] = d, lo_d, hi_d - lo_d
                break
    bins = np.ones(DIMS, dtype=np.int64)
    cells = 1
    for e in range(DIMS):
        if dim[e] >= 0:
            bins[e] = min(BINS, spread[e] + 1)
        cells *= bins[e]
    cell = np.empty(m, dtype=np.int64)
    start = np.zeros(cells + 1, dtype=np.int64)  # where each cell's keys begin in k_key
    for h in range(m):
        x = 0
        for e in range(DIMS):
            x = x * bins[e] + _bin(key[h], dim[e], lo[e], spread[e], bins[e])
        cell[h] = x
        start[x + 1] += 1
    for x in range(cells):
        start[x + 1] += start[x]
    filled = np.zeros(cells, dtype=np.int64)  # how many keys each cell holds
    k_key = np.empty((m, key.shape[1]), dtype=np.uint64)  # the kept candidates' keys, each cell's side by side
    at = np.empty(DIMS, dtype=np.int64)
    nk = 0
    last = -1
    for j in range(m):
        if (j & 255) == 0 and halt[0]:
            return -1
        c = order[j]
        if last >= 0 and _ranks_geq(k_key[last], key[c]):
            continue
        for e in range(DIMS):
            at[e] = _bin(key[c], dim[e], lo[e], spread[e], bins[e])
        h = _dominator(k_key, key[c], start, filled, at, bins)
        if h >= 0:
            last = h
            continue
        h = start[cell[c]] + filled[cell[c]]
        k_key[h] = key[c]
        filled[cell[c]] += 1
        kept[nk] = c
        nk += 1
    return nk


@njit(cache=True, inline="always")
def _bin(key, d, lo, spread, bins):
    """The cell, 0..bins-1, of a key along lane d of the filter's grid (0 if unused)."""
    if d < 0:
        return 0
    return (_lane(key, d) - lo) * bins // (spread + 1)


@njit(cache=True, inline="always")
def _dominator(k_key, key, start, filled, at, bins):
    """A kept key (its place in k_key) with every lane at least ``key``'s, or -1: from the
    cells at or above ``at`` along each of the grid's DIMS (= 3) lanes, newest first."""
    for b0 in range(at[0], bins[0]):
        for b1 in range(at[1], bins[1]):
            base = (b0 * bins[1] + b1) * bins[2]
            for b2 in range(at[2], bins[2]):
                x = base + b2
                for h in range(start[x] + filled[x] - 1, start[x] - 1, -1):
                    if _ranks_geq(k_key[h], key):
                        return h
    return -1


@njit(cache=True)
def _bound_and_collapse(mode, rank, acc, q, tau, W, best_rank, matters, collapse, tdma, scratch, pair, lo_buf,
                        hi_buf, steps, iscratch):
    """Admissible bound on the final value of a label in slot tau at q, and collapse in place.

    Future slot t2 > tau: sensor i's value is at most W[i, max(rank_i, best_rank), t2] and at
    least W[i, rank_i, t2]. A sensor whose lowest possible value exceeds some other sensor's
    highest possible value (or, for min accumulation, is already >= acc) is never the binding
    minimum in any completion: its rank is set to the collapsed rank (exact, docs/dp.md).
    With ``tdma`` the slot term is tightened by the bounds of _dp_bounds: distinct ages always,
    the pairwise bound when ``pair`` is not empty and the tour bound when ``steps`` is not."""
    N = rank.shape[0]
    T = W.shape[2] - 1
    big = W.shape[1] - 1
    ub = acc
    for i in range(N):
        matters[i] = False
    for t2 in range(tau + 1, T + 1):
        m1 = np.inf
        m2 = np.inf
        a1 = -1
        for i in range(N):
            r = rank[i]
            b = best_rank[i, q, tau, t2]
            if b > r:
                r = b
            u = W[i, r, t2]
            hi_buf[i] = u  # the per-sensor bound, which the tight bounds read again
            if u < m1:
                m2 = m1
                m1 = u
                a1 = i
            elif u < m2:
                m2 = u
        term = m1
        if tdma and N > 1:
            term = distinct_ages_bound(rank, q, tau, t2, W, best_rank, m1, scratch)
            if pair.shape[0] > 0:
                v = pair_bound(rank, q, tau, t2, W, pair, lo_buf, hi_buf)
                if v < term:
                    term = v
            if steps.shape[0] > 0:
                term = tour_bound(rank, q, tau, t2, W, best_rank, steps, term, hi_buf, iscratch[:N], iscratch[N:])
        if mode == SUM:
            ub += term
        elif term < ub:
            ub = term
        if collapse:
            for i in range(N):
                if matters[i]:
                    continue
                lo = W[i, rank[i], t2]
                other = m2 if i == a1 else m1
                if lo > other:
                    continue
                if mode == MIN and lo >= acc:
                    continue
                matters[i] = True
    if collapse:
        for i in range(N):
            if not matters[i]:
                rank[i] = big
    return ub


@njit(cache=True, inline="always")
def best_of(kept, nk, ub, beam):
    """A beam pass (beam > 0): of the nk kept labels, the ``beam`` of best bound (ties: the
    first), in their order, at the front of ``kept``; returns how many are kept."""
    if beam <= 0 or nk <= beam:
        return nk
    sel = np.sort(np.argsort(-ub[kept[:nk]], kind="mergesort")[:beam])
    for h in range(beam):
        kept[h] = kept[sel[h]]
    return beam


@njit(cache=True, inline="always")
def _improving(o, p, t, ranks, l, in_range_list, up_rank):
    """Upload choice o at p: -1 for none (o < 0), else the o-th sensor in range, or -2 when that
    upload does not raise the sensor's rank (such a child is dominated by its sibling)."""
    if o < 0:
        return -1
    u = in_range_list[p, o]
    return u if up_rank[t, p, u] > ranks[l, u] else -2


@njit(cache=True, inline="always")
def _bound_buffers(N):
    """_bound_and_collapse's working arrays: matters, scratch, lo, hi, iscratch."""
    return np.zeros(N, dtype=np.bool_), np.empty(N), np.empty(N), np.empty(N), np.empty(2 * N, dtype=np.int64)


@njit(cache=True, inline="always")
def _label_arrays(n, N):
    """Room for n labels of N sensors: ranks, acc, ub, parent, upload, moves left."""
    return (np.empty((n, N), dtype=np.int16), np.empty(n), np.empty(n), np.empty(n, dtype=np.int64),
            np.empty(n, dtype=np.int16), np.empty(n, dtype=np.int16))


@njit(cache=True)
def label_bounds(mode, t, ranks, acc, pos, W, best_rank, collapse, tdma, pair, steps):
    """Bound (and collapse) of every label of one layer: used for the start label."""
    L, N = ranks.shape
    ub = np.empty(L)
    matters, scratch, lo, hi, iscratch = _bound_buffers(N)
    for l in range(L):
        ub[l] = _bound_and_collapse(mode, ranks[l], acc[l], pos[l], t, W, best_rank, matters, collapse, tdma,
                                    scratch, pair, lo, hi, steps, iscratch)
    return ub


@njit(cache=True, nogil=True)
def expand(mode, t, ranks, acc, ub_in, left, off, nbr, up_rank, in_range_list, in_range_count, W, best_rank,
           incumbent, q_lo, q_hi, beam, collapse, tdma, pair, steps, to_end, budget_lane, halt):
    """Children in slot t+1 at target points q_lo..q_hi-1 of the layer in slot t.

    Returns the non-dominated children whose bound beats ``incumbent`` and that can still reach
    ``end`` (``to_end``) within the slots and moves left, grouped by point: (ranks, acc, ub,
    parent, upload, pos, count per point, children generated, halted, moves left).
    It runs without the GIL, and gives up (halted, with no children) as soon as ``halt[0]``
    is set by the thread that watches the stop rule."""
    N = ranks.shape[1]
    tau = t + 1
    T = W.shape[2] - 1
    slots_left = T - 1 - tau  # moves the entity can still make after slot tau
    # capacity: every (label, upload) pair of every source point
    cap = 0
    max_m = 0
    for q in range(q_lo, q_hi):
        m = 0
        for p in nbr[q]:
            if p >= 0:
                m += (off[p + 1] - off[p]) * (1 + in_range_count[p])
        cap += m
        if m > max_m:
            max_m = m
    out_rank, out_acc, out_ub, out_par, out_up, out_left = _label_arrays(cap, N)
    out_pos = np.empty(cap, dtype=np.int32)
    counts = np.zeros(q_hi - q_lo, dtype=np.int64)
    NL = N + budget_lane  # lanes of the dominance test: the ranks, and the moves left with a budget
    NW = (NL + 3) // 4  # lanes packed four 16 bits to a word
    c_key = np.zeros((max_m, NW), dtype=np.uint64)
    c_rank, c_acc, c_ub, c_par, c_up, c_left = _label_arrays(max_m, N)
    c_sum = np.empty(max_m)
    kept = np.empty(max_m, dtype=np.int64)
    matters, scratch, lo, hi, iscratch = _bound_buffers(N)
    no_pair = np.empty((0, 0, 0, 0, 0))
    no_steps = np.empty((0, 0), dtype=np.int64)
    child = np.empty(N, dtype=np.int16)
    n_out, generated = 0, 0
    for q in range(q_lo, q_hi):
        m = 0
        for k in range(5):
            p = nbr[q, k]  # moves are symmetric: q is one move from p iff p is one move from q
            if p < 0:
                continue
            for l in range(off[p], off[p + 1]):
                lf = left[l] - (1 if p != q else 0)
                if lf < 0 or to_end[q] > min(lf, slots_left):
                    continue  # over the budget, or no way left to end
                if lf > slots_left:
                    lf = slots_left  # moves beyond the slots left are worth nothing
                if halt[0]:
                    return _children(0, out_rank, out_acc, out_ub, out_par, out_up, out_pos, out_left, counts, generated,
                                     True)
                if ub_in[l] <= incumbent:
                    continue
                for o in range(-1, in_range_count[p]):
                    u = -1
                    if o >= 0:
                        u = in_range_list[p, o]
                        if up_rank[t, p, u] <= ranks[l, u]:
                            continue  # an upload that does not improve is dominated by none
                    a = _child(mode, ranks[l], acc[l], u, up_rank[t, p], W, tau, child)
                    generated += 1
                    ub = _bound_and_collapse(mode, child, a, q, tau, W, best_rank, matters, collapse, False, scratch,
                                             no_pair, lo, hi, no_steps, iscratch)
                    if ub <= incumbent:
                        continue
                    s = 0.0
                    for w in range(NW):
                        c_key[m, w] = 0
                    for i in range(N):
                        c_rank[m, i] = child[i]
                        c_key[m, i // 4] |= np.uint64(child[i]) << np.uint64(16 * (i % 4))
                        s += child[i]
                    if budget_lane:
                        c_key[m, N // 4] |= np.uint64(lf) << np.uint64(16 * (N % 4))
                        s += lf
                    c_left[m] = lf
                    c_sum[m] = -s
                    c_acc[m] = -a
                    c_ub[m] = ub
                    c_par[m] = l
                    c_up[m] = u
                    m += 1
        if m == 0:
            continue
        nk = pareto(c_key, c_acc, c_sum, m, NL, kept, halt)
        if nk < 0:
            return _children(0, out_rank, out_acc, out_ub, out_par, out_up, out_pos, out_left, counts, generated, True)
        if tdma:  # the costlier bound only for the survivors of the filter
            nt = 0
            for h in range(nk):
                c = kept[h]
                ub = _bound_and_collapse(mode, c_rank[c], -c_acc[c], q, tau, W, best_rank, matters, False, True,
                                         scratch, pair, lo, hi, steps, iscratch)
                if ub > incumbent:
                    c_ub[c] = min(ub, c_ub[c])
                    kept[nt] = c
                    nt += 1
            nk = nt
        nk = best_of(kept, nk, c_ub, beam)
        for h in range(nk):
            c = kept[h]
            for i in range(N):
                out_rank[n_out, i] = c_rank[c, i]
            out_acc[n_out] = -c_acc[c]
            out_ub[n_out] = c_ub[c]
            out_par[n_out] = c_par[c]
            out_up[n_out] = c_up[c]
            out_pos[n_out] = q
            out_left[n_out] = c_left[c]
            n_out += 1
        counts[q - q_lo] = nk
    return _children(n_out, out_rank, out_acc, out_ub, out_par, out_up, out_pos, out_left, counts, generated, False)


@njit(cache=True, inline="always")
def _children(n, rank, acc, ub, par, up, pos, left, counts, generated, halted):
    """expand's answer: the first n children (none when halted), as fresh arrays."""
    return (rank[:n].copy(), acc[:n].copy(), ub[:n].copy(), par[:n].copy(), up[:n].copy(), pos[:n].copy(), counts,
            generated, halted, left[:n].copy())


@njit(cache=True)
def finish(mode, t, ranks, acc, pos, up_rank, in_range_list, in_range_count, W):
    """The best complete plan from the last layer (slot T-1): (value, label, upload)."""
    N = ranks.shape[1]
    T = t + 1
    best, best_l, best_u = -np.inf, -1, -1
    child = np.empty(N, dtype=np.int16)
    for l in range(ranks.shape[0]):
        p = pos[l]
        for o in range(-1, in_range_count[p]):
            u = _improving(o, p, t, ranks, l, in_range_list, up_rank)
            if u != -2:  # (-2: an upload that does not improve)
                a = _child(mode, ranks[l], acc[l], u, up_rank[t, p], W, T, child)
                if a > best:
                    best, best_l, best_u = a, l, u
    return best, best_l, best_u
