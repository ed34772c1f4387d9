"""Compiled kernels of the two-robot label-setting programme (voiopt/solvers/dp/fleet.py, docs/dp.md).

The ranks, worth table ``W`` and ``best_rank`` are the one-robot programme's (see labels.kernels):
they depend on the network, not on the robot. A label here is (slot, p0, p1, moves left of
each robot, ranks, accumulated value); a layer's labels are grouped by the *bucket*
p0 * n + p1, ``off`` giving each bucket's range. Within a bucket a label is kept unless another
has an accumulated value and every lane (the N ranks and the two robots' moves left) at least
as high: every joint completion of the dropped label is then open to the kept one and ends at
least as well (docs/dp.md, "Several robots").
"""

from __future__ import annotations

import numpy as np

from voiopt.runtime.jit import njit
from voiopt.solvers.labels.kernels import SUM, best_of, combine, pareto


@njit(cache=True, inline="always")
def _bound2(mode, rank, acc, q0, q1, tau, W, best_rank):
    """Admissible bound on the final value of a label in slot tau with robots at q0 and q1:
    each sensor gets the best rank either robot alone could give it (the rules between robots
    and one upload per robot and slot relaxed)."""
    N = rank.shape[0]
    T = W.shape[2] - 1
    ub = acc
    for t2 in range(tau + 1, T + 1):
        m = np.inf
        for i in range(N):
            m = min(m, W[i, max(rank[i], best_rank[i, q0, tau, t2], best_rank[i, q1, tau, t2]), t2])
        ub = combine(mode, ub, m)
    return ub


@njit(cache=True, inline="always")
def _children_of(rank, u0, u1, up0, up1, child):
    """The ranks after robot 0 uploads u0 and robot 1 uploads u1 (-1: none) into ``child``.
    False when the pair is not worth generating: both the same sensor (a sensor uploads to one
    robot per slot), or an upload that does not raise the rank (the child without it has the
    same state and is generated too)."""
    if u0 >= 0 and u0 == u1:
        return False
    if u0 >= 0 and up0[u0] <= rank[u0]:
        return False
    if u1 >= 0 and up1[u1] <= rank[u1]:
        return False
    for i in range(rank.shape[0]):
        child[i] = rank[i]
    if u0 >= 0:
        child[u0] = up0[u0]
    if u1 >= 0:
        child[u1] = up1[u1]
    return True


@njit(cache=True, inline="always")
def _slot_worth(child, W, t2):
    w = np.inf
    for i in range(child.shape[0]):
        w = min(w, W[i, child[i], t2])
    return w


@njit(cache=True, inline="always")
def _uploads(in_range_count, p, uploads):
    """The upload choices of a robot at p: none, and (with ``uploads``) each sensor in range."""
    return 1 + (in_range_count[p] if uploads else 0)


@njit(cache=True, inline="always")
def _sources(nbr, q0, q1, src):
    """The point pairs (p0, p1) one joint move before (q0, q1), into ``src``; returns how many.
    None for a shared point; a swap (p0, p1) = (q1, q0) is left out."""
    if q0 == q1:
        return 0
    k = 0
    for p0 in nbr[q0]:  # moves are symmetric: p is one move from q iff q is one move from p
        for p1 in nbr[q1]:
            if p0 >= 0 and p1 >= 0 and not (p0 == q1 and p1 == q0):
                src[k, 0], src[k, 1] = p0, p1
                k += 1
    return k


@njit(cache=True, nogil=True)
def expand(mode, t, ranks, acc, ub_in, left0, left1, off, nbr, up_rank, in_range_list, in_range_count, W,
           best_rank, to_end0, to_end1, incumbent, b_lo, b_hi, beam, uploads, halt):
    """Children in slot t+1 in target buckets b_lo..b_hi-1 of the layer in slot t.

    A child keeps every rule of MODEL.md section 10: each robot one of its five moves (``nbr``
    is symmetric, so sources are the targets' neighbours), no shared point, no swap, its own
    budget and a way left to its own end; one upload per robot within range, a sensor to one
    robot. Returns the non-dominated children whose bound beats ``incumbent``, grouped by
    bucket: (ranks, (acc, bound), (parent, upload0, upload1, p0, p1, left0, left1), count per
    bucket, children generated, halted). Gives up (halted, no children) once ``halt[0]`` is set.
    Without ``uploads`` (the pass that looks for a legal plan) no bound is computed (+inf)."""
    N = ranks.shape[1]
    n = nbr.shape[0]
    tau = t + 1
    T = W.shape[2] - 1
    slots_left = T - 1 - tau
    cap = 0
    max_m = 0
    src = np.empty((25, 2), dtype=np.int64)
    for b in range(b_lo, b_hi):
        m = 0
        for k in range(_sources(nbr, b // n, b % n, src)):
            p0, p1 = src[k, 0], src[k, 1]
            s = p0 * n + p1
            m += (off[s + 1] - off[s]) * _uploads(in_range_count, p0, uploads) * _uploads(in_range_count, p1, uploads)
        cap += m
        if m > max_m:
            max_m = m
    if beam > 0 and cap > beam * (b_hi - b_lo):
        cap = beam * (b_hi - b_lo)
    # records: ranks; (acc, bound); (parent, upload0, upload1, p0, p1, left0, left1)
    out_rank = np.empty((cap, N), dtype=np.int16)
    out_val = np.empty((cap, 2))
    out_int = np.empty((cap, 7), dtype=np.int64)
    counts = np.zeros(b_hi - b_lo, dtype=np.int64)
    NW = (N + 2 + 3) // 4  # lanes (ranks, then both robots' moves left) packed four 16 bits to a word
    c_key = np.zeros((max_m, NW), dtype=np.uint64)
    c_rank = np.empty((max_m, N), dtype=np.int16)
    c_acc = np.empty(max_m)  # negated: the filter sorts ascending
    c_sum = np.empty(max_m)
    c_ub = np.empty(max_m)
    c_int = np.empty((max_m, 7), dtype=np.int64)
    kept = np.empty(max_m, dtype=np.int64)
    child = np.empty(N, dtype=np.int16)
    n_out = 0
    generated = 0
    for b in range(b_lo, b_hi):
        q0, q1 = b // n, b % n
        m = 0
        for k in range(_sources(nbr, q0, q1, src)):
            p0, p1 = src[k, 0], src[k, 1]
            s = p0 * n + p1
            n0 = _uploads(in_range_count, p0, uploads)
            n1 = _uploads(in_range_count, p1, uploads)
            for l in range(off[s], off[s + 1]):
                if halt[0]:
                    return _empty(N, counts, generated)
                lf0 = left0[l] - (1 if p0 != q0 else 0)
                lf1 = left1[l] - (1 if p1 != q1 else 0)
                if ub_in[l] <= incumbent or min(lf0, lf1) < 0:
                    continue  # cannot beat the incumbent, or over a budget
                if to_end0[q0] > min(lf0, slots_left) or to_end1[q1] > min(lf1, slots_left):
                    continue  # no way left to an end
                lf0 = min(lf0, slots_left)  # moves beyond the slots left are worth nothing
                lf1 = min(lf1, slots_left)
                for o0 in range(-1, n0 - 1):
                    u0 = -1 if o0 < 0 else in_range_list[p0, o0]
                    for o1 in range(-1, n1 - 1):
                        u1 = -1 if o1 < 0 else in_range_list[p1, o1]
                        if not _children_of(ranks[l], u0, u1, up_rank[t, p0], up_rank[t, p1], child):
                            continue
                        generated += 1
                        a = combine(mode, acc[l], _slot_worth(child, W, tau))
                        ub = _bound2(mode, child, a, q0, q1, tau, W, best_rank) if uploads else np.inf
                        if ub <= incumbent:
                            continue
                        c_rank[m] = child
                        c_sum[m] = -_pack(child, lf0, lf1, c_key[m])
                        c_acc[m] = -a
                        c_ub[m] = ub
                        c_int[m, 0], c_int[m, 1], c_int[m, 2], c_int[m, 3] = l, u0, u1, q0
                        c_int[m, 4], c_int[m, 5], c_int[m, 6] = q1, lf0, lf1
                        m += 1
        if m == 0:
            continue
        nk = pareto(c_key, c_acc, c_sum, m, N + 2, kept, halt)
        if nk < 0:
            return _empty(N, counts, generated)
        nk = best_of(kept, nk, c_ub, beam)  # a heuristic pass: the labels of best bound
        for h in range(nk):
            c = kept[h]
            out_rank[n_out] = c_rank[c]
            out_val[n_out, 0] = -c_acc[c]
            out_val[n_out, 1] = c_ub[c]
            out_int[n_out] = c_int[c]
            n_out += 1
        counts[b - b_lo] = nk
    return out_rank[:n_out].copy(), out_val[:n_out].copy(), out_int[:n_out].copy(), counts, generated, False


@njit(cache=True, inline="always")
def _pack(child, lf0, lf1, key):
    """The lanes of the dominance test (ranks, then both robots' moves left) into ``key``, four
    16 bits to a word; returns their sum (the filter's second sort key)."""
    N = child.shape[0]
    key[:] = 0
    total = 0.0
    for i in range(N + 2):
        v = child[i] if i < N else (lf0 if i == N else lf1)
        key[i // 4] |= np.uint64(v) << np.uint64(16 * (i % 4))
        total += v
    return total


@njit(cache=True)
def _empty(N, counts, generated):
    return np.empty((0, N), dtype=np.int16), np.empty((0, 2)), np.empty((0, 7), dtype=np.int64), counts, generated, True


@njit(cache=True)
def finish(mode, ranks, acc, pos0, pos1, up_rank, in_range_list, in_range_count, W, uploads):
    """The best complete plan from the last layer (slot T-1): (value, label, upload0, upload1)."""
    N = ranks.shape[1]
    T = W.shape[2] - 1
    best = -np.inf
    best_l = -1
    best_u0 = -1
    best_u1 = -1
    child = np.empty(N, dtype=np.int16)
    for l in range(ranks.shape[0]):
        p0, p1 = pos0[l], pos1[l]
        for o0 in range(-1, _uploads(in_range_count, p0, uploads) - 1):
            u0 = -1 if o0 < 0 else in_range_list[p0, o0]
            for o1 in range(-1, _uploads(in_range_count, p1, uploads) - 1):
                u1 = -1 if o1 < 0 else in_range_list[p1, o1]
                if not _children_of(ranks[l], u0, u1, up_rank[T - 1, p0], up_rank[T - 1, p1], child):
                    continue
                a = combine(mode, acc[l], _slot_worth(child, W, T))
                if a > best:
                    best, best_l, best_u0, best_u1 = a, l, u0, u1
    return best, best_l, best_u0, best_u1


__all__ = ["SUM", "expand", "finish"]
