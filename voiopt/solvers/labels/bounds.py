"""Compiled slot bounds of the label-setting programme (docs/dp.md, "Bounds"): upper bounds on
min_i V_i(t2) in a later slot t2 for a label in slot tau at point q with ranks ``rank``, each
tighter than the per-sensor relaxation (``best_rank``) that labels.kernels applies to every child.

- ``distinct_ages_bound``: one upload per slot, so of any k sensors one was refreshed k - 1
  slots before the last;
- ``pair_bound``: two sensors both fresh need both uploads and the walk between them;
- ``tour_bound``: k sensors all refreshed need a walk through all their ranges, so the oldest
  of those uploads is at least a lower bound on that walk's length before the last.
"""

from __future__ import annotations

import numpy as np

from voiopt.runtime.jit import njit

FAR = 1 << 30  # moves between two sensors' ranges when one has no point in range (never served)


@njit(cache=True)
def pair_table(W, up_rank, point_steps, sensor_points, sensor_point_count):
    """pair[i, j, tau, q, t2]: the best min(V_i(t2), V_j(t2)) when both are refreshed in slots
    tau..t2-1, i before j, by an entity at q in slot tau; -inf where impossible.

    j's upload is best made in slot t2-1 (later is better), at a point within the steps left
    after i's upload; i's at any reachable point and slot. Suffix maxima over i's slot make the
    table O(pairs * T * (T * n + T * points^2))."""
    T, n, N = up_rank.shape
    out = np.full((N, N, T, n, T + 1), -np.inf)
    P = sensor_points.shape[1]
    H = np.empty((P, T))
    for i in range(N):
        for j in range(N):
            if i == j:
                continue
            for t2 in range(2, T + 1):
                for ai in range(sensor_point_count[i]):
                    a = sensor_points[i, ai]
                    h = -np.inf
                    for s in range(t2 - 2, -1, -1):
                        bj = -np.inf
                        for bi in range(sensor_point_count[j]):
                            b = sensor_points[j, bi]
                            if point_steps[j, bi, a] <= t2 - 1 - s:
                                v = W[j, up_rank[t2 - 1, b, j], t2]
                                if v > bj:
                                    bj = v
                        g = min(W[i, up_rank[s, a, i], t2], bj)
                        if g > h:
                            h = g
                        H[ai, s] = h
                for tau in range(0, t2 - 1):
                    for q in range(n):
                        best = -np.inf
                        for ai in range(sensor_point_count[i]):
                            a = sensor_points[i, ai]
                            sigma = tau + point_steps[i, ai, q]
                            if sigma <= t2 - 2 and H[ai, sigma] > best:
                                best = H[ai, sigma]
                        out[i, j, tau, q, t2] = best
    return out


@njit(cache=True)
def pair_bound(rank, q, tau, t2, W, pair, lo, hi):
    """Upper bound on min_i V_i(t2) from every pair of sensors: both fresh needs both uploads,
    in order, with the travel between them (pair_table); otherwise one keeps its value.
    ``hi`` holds each sensor's per-sensor bound in t2 (filled by the caller); ``lo`` is scratch."""
    N = rank.shape[0]
    for i in range(N):
        lo[i] = W[i, rank[i], t2]
    best = np.inf
    for i in range(N):
        for j in range(i + 1, N):
            p = min(lo[i], hi[j])
            v = min(hi[i], lo[j])
            if v > p:
                p = v
            v = pair[i, j, tau, q, t2]
            if v > p:
                p = v
            v = pair[j, i, tau, q, t2]
            if v > p:
                p = v
            if p < best:
                best = p
    return best


@njit(cache=True)
def distinct_ages_bound(rank, q, tau, t2, W, best_rank, per_slot, c):
    """Upper bound on min_i V_i(t2) that respects one upload per slot.

    Among any k sensors, either one is not refreshed in slots tau..t2-1 (value <= its current
    one) or all are, in distinct slots, so one was refreshed at least k slots before t2 (value
    <= its best from an upload in slot <= t2-k). So for every k the k-th smallest of
    c_i(k) = W[i, max(rank_i, best rank by slot t2-k), t2] bounds the slot; k = 1 is the
    per-sensor relaxation ``per_slot``."""
    N = rank.shape[0]
    best = per_slot
    for k in range(2, N + 1):
        tp = t2 - k + 1  # best_rank[.., tp] covers uploads in slots tau..t2-k
        for i in range(N):
            r = rank[i]
            if tp > tau:
                b = best_rank[i, q, tau, tp]
                if b > r:
                    r = b
            c[i] = W[i, r, t2]
        below = 0  # the k-th smallest is below the best so far iff k values are
        for i in range(N):
            if c[i] < best:
                c[below] = c[i]
                below += 1
        if below >= k:  # k-th smallest of the values below, by partial selection sort
            for a in range(k):
                m = a
                for b2 in range(a + 1, below):
                    if c[b2] < c[m]:
                        m = b2
                c[a], c[m] = c[m], c[a]
            best = c[k - 1]
        if tp <= tau:
            break  # larger k only sees current values: their k-th smallest can only grow
    return best


@njit(cache=True)
def range_steps(point_steps, sensor_points, sensor_point_count):
    """D[i, j]: the fewest moves between a point in range of sensor i and one in range of
    sensor j (0 where the ranges share a point; FAR where either has no point in range)."""
    N = sensor_points.shape[0]
    out = np.full((N, N), FAR, dtype=np.int64)
    for i in range(N):
        for j in range(N):
            for a in range(sensor_point_count[i]):
                for b in range(sensor_point_count[j]):
                    d = point_steps[i, a, sensor_points[j, b]]
                    if d < out[i, j]:
                        out[i, j] = d
    return out


@njit(cache=True)
def tour_bound(rank, q, tau, t2, W, best_rank, steps, per_slot, hi, order, nn):
    """Upper bound on min_i V_i(t2) from the walk that refreshing several sensors needs.

    Take a set S of sensors. Either one of them is not refreshed in slots tau..t2-1 (its worth
    is its current one) or all are, at points of their ranges in distinct slots; the robot
    moves at most one step per slot, so the oldest of those uploads is at least
    m(S) = sum over consecutive uploads of max(1, steps between the two ranges) slots before
    the newest (<= t2 - 1). Every order of S visits each sensor but the first from another one,
    at least its nearest (>= 1) away, so m(S) >= sum_S nn_i - max_S nn_i. Either way some
    i in S has worth <= c_i = W[i, max(rank_i, best rank from an upload by slot t2 - 1 - m), t2],
    so min_i V_i(t2) <= max_{i in S} c_i. S runs over the prefixes of the sensors sorted by their
    per-sensor bound (the weakest first); any S gives a bound, so the smallest is taken.
    ``hi`` holds those per-sensor bounds in t2 (filled by the caller); ``order`` and ``nn`` are
    scratch arrays of length N."""
    N = rank.shape[0]
    for i in range(N):  # sorted by insertion into ``order``
        k = i
        while k > 0 and hi[order[k - 1]] > hi[i]:
            order[k] = order[k - 1]
            k -= 1
        order[k] = i
    best = per_slot
    for k in range(N):
        x = order[k]
        nn[k] = FAR
        for j in range(k):
            d = steps[x, order[j]]
            if d < 1:
                d = 1
            if d < nn[j]:
                nn[j] = d
            if d < nn[k]:
                nn[k] = d
        if k == 0:
            continue
        total = 0
        longest = 0
        for j in range(k + 1):
            total += nn[j]
            if nn[j] > longest:
                longest = nn[j]
        tp = t2 - (total - longest)  # best_rank[.., tp] covers uploads in slots tau..tp-1
        worst = -np.inf
        for j in range(k + 1):
            i = order[j]
            r = rank[i]
            if tp > tau:
                b = best_rank[i, q, tau, tp]
                if b > r:
                    r = b
            v = W[i, r, t2]
            if v > worst:
                worst = v
                if worst >= best:
                    break
        if worst < best:
            best = worst
        if tp <= tau:
            break  # larger sets only add current worths to the maximum: no better bound
    return best
