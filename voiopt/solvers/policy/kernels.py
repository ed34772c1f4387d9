"""Compiled kernels of the layered expectimax (``layered.py``) over packed states (``packed.py``).

A layer is the sorted array of the distinct keys of one slot's reachable states. ``expand``
writes the next states of a run of a layer's states (every legal action, every outcome of
probability > 0); ``compact`` and ``merge`` make the next layer of them. ``backward`` values a
run of states from the next layer's worths (reward + value), in the plain expectimax's order
and arithmetic (voiopt.solvers.policy.expectimax): for each upload (none, then the sensors in
range) and each move (stay, N, S, E, W), total = 0.0 + p_success * worth_success +
p_fail * worth_fail, the first strictly larger total kept. ``follow`` takes the optimal
action of each state the policy reaches and its outcomes.

``fields`` holds the point mask, the moves' shift and mask, the position fields' width and the
step that ages every sensor by one slot; an action is coded (u + 1) * 5 + m.
"""

from __future__ import annotations

import numpy as np

from voiopt.runtime.jit import njit

P_MASK, K_SHIFT, K_MASK, LOW_BITS, AGE_STEP = 0, 1, 2, 3, 4


@njit(cache=True, inline="always")
def lower_bound(keys, lo, hi, x):
    """The first index in [lo, hi) whose key is >= x (hi if none)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if keys[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True, inline="always")
def gallop(keys, lo, x):
    """``lower_bound(keys, lo, len(keys), x)``, in steps that double from lo: quick where the
    answer is near lo."""
    n = keys.shape[0]
    step = 1
    while lo + step < n and keys[lo + step] < x:
        lo += step
        step *= 2
    return lower_bound(keys, lo, min(n, lo + step + 1), x)


@njit(cache=True, inline="always")
def index_of(keys, block, span, x):
    """The index of key x, searched among the ``span`` keys from ``block``, where the keys that
    share x's ages and distances start; -1 if it is not there."""
    hi = min(keys.shape[0], block + span)
    i = lower_bound(keys, block, hi, x)
    if i < hi and keys[i] == x:
        return i
    return -1


@njit(cache=True, inline="always")
def position(key, fields):
    """The point and the moves used of a key."""
    return key & fields[P_MASK], (key >> fields[K_SHIFT]) & fields[K_MASK]


@njit(cache=True, inline="always")
def aged(key, fields):
    """The key with its position fields cleared and every sensor one slot older."""
    low = fields[LOW_BITS]
    return ((key >> low) << low) + fields[AGE_STEP]


@njit(cache=True, inline="always")
def reward(key, voi_model, voi, a_shift, a_mask, q_shift, q_mask):
    """r of a state: min_i V_i, or -max_i A_i (as Steps.reward)."""
    N = a_shift.shape[0]
    if voi_model:
        r = voi[0, (key >> a_shift[0]) & a_mask[0], (key >> q_shift[0]) & q_mask[0]]
        for i in range(1, N):
            v = voi[i, (key >> a_shift[i]) & a_mask[i], (key >> q_shift[i]) & q_mask[i]]
            if v < r:
                r = v
        return r
    m = (key >> a_shift[0]) & a_mask[0]
    for i in range(1, N):
        a = (key >> a_shift[i]) & a_mask[i]
        if a > m:
            m = a
    return -float(m)


@njit(cache=True)
def expand(keys, lo, hi, t, mv_n, mv_low, up_n, up_u, win_clear, win_set, fields, out):
    """The next states of keys[lo:hi] in slot t, into ``out`` (with repeats); returns how many.
    A failed upload's next state is the no-upload one of the same move, written once; and a
    run of keys of equal ages and distances writes each of its no-upload next states once."""
    c = 0
    seen = np.zeros(np.int64(1) << fields[LOW_BITS], dtype=np.int64)  # the run of equal ages that wrote a position
    run, last = 0, -1
    for s in range(lo, hi):
        p, k = position(keys[s], fields)
        base = aged(keys[s], fields)
        if base != last:
            run, last = run + 1, base
        nm = mv_n[t, p, k]
        for j in range(nm):
            low = mv_low[t, p, k, j]
            if seen[low] != run:
                seen[low] = run
                out[c] = base | low
                c += 1
        for ju in range(1, up_n[t, p]):
            u = up_u[t, p, ju]
            won = (base & win_clear[u]) | win_set[u, p]
            for j in range(nm):
                out[c] = won | mv_low[t, p, k, j]
                c += 1
    return c


RADIX = 8  # bits of a key sorted per pass


@njit(cache=True)
def radix_sort(a, n, tmp, bits):
    """Sort a[:n] in place (keys of at most ``bits`` bits; ``tmp`` as large): least significant
    digit first, RADIX bits a pass, about six times numpy's sort on these keys."""
    passes = (bits + RADIX - 1) // RADIX
    size = 1 << RADIX
    mask = size - 1
    counts = np.zeros((passes, size), dtype=np.int64)
    for i in range(n):
        x = a[i]
        for d in range(passes):
            counts[d, (x >> (d * RADIX)) & mask] += 1
    src, dst = a, tmp
    for d in range(passes):
        total = 0
        for b in range(size):
            c = counts[d, b]
            counts[d, b] = total
            total += c
        shift = d * RADIX
        for i in range(n):
            x = src[i]
            b = (x >> shift) & mask
            dst[counts[d, b]] = x
            counts[d, b] += 1
        src, dst = dst, src
    if passes % 2 == 1:
        for i in range(n):
            a[i] = src[i]


@njit(cache=True)
def compact(a, n):
    """Remove the repeats of the sorted a[:n] in place; returns how many distinct keys."""
    if n == 0:
        return 0
    m = 1
    for i in range(1, n):
        if a[i] != a[m - 1]:
            a[m] = a[i]
            m += 1
    return m


@njit(cache=True)
def merge(a, b):
    """The sorted union of two sorted arrays of distinct keys (a view of a buffer that had room
    for both)."""
    out = np.empty(a.shape[0] + b.shape[0], dtype=np.int64)
    i = j = c = 0
    while i < a.shape[0] and j < b.shape[0]:
        if a[i] < b[j]:
            out[c] = a[i]
            i += 1
        elif b[j] < a[i]:
            out[c] = b[j]
            j += 1
        else:
            out[c] = a[i]
            i += 1
            j += 1
        c += 1
    while i < a.shape[0]:
        out[c] = a[i]
        i += 1
        c += 1
    while j < b.shape[0]:
        out[c] = b[j]
        j += 1
        c += 1
    return out[:c]


@njit(cache=True)
def rewards(keys, lo, hi, voi_model, voi, a_shift, a_mask, q_shift, q_mask, out):
    """What reaching each state of the last layer is worth: its reward + 0.0 (no slot left)."""
    for s in range(lo, hi):
        out[s] = reward(keys[s], voi_model, voi, a_shift, a_mask, q_shift, q_mask) + 0.0


@njit(cache=True)
def backward(keys, lo, hi, t, nxt, nxt_worth, mv_n, mv_m, mv_low, up_n, up_u, up_ps, win_clear, win_set, fields,
             voi_model, voi, a_shift, a_mask, q_shift, q_mask, with_reward, out_worth, out_act):
    """Values keys[lo:hi] in slot t: ``out_act`` the optimal action's code, ``out_worth`` the
    value (+ the state's reward where ``with_reward``). Returns the number of next states not
    found in ``nxt`` (0, unless the layers are inconsistent)."""
    span = np.int64(1) << fields[LOW_BITS]
    fail = np.empty(5)
    missing = 0
    # where the next states of a run of keys start: the runs' aged keys rise with the keys
    # (ageing keeps the order), and the keys before and after an upload repeat along a run
    block, last = 0, -1
    wlast = np.full(win_clear.shape[0], -1, dtype=np.int64)
    wblocks = np.zeros(win_clear.shape[0], dtype=np.int64)
    for s in range(lo, hi):
        p, k = position(keys[s], fields)
        base = aged(keys[s], fields)
        nm = mv_n[t, p, k]
        if base != last:
            block, last = gallop(nxt, block, base), base
        for j in range(nm):
            i = index_of(nxt, block, span, base | mv_low[t, p, k, j])
            if i < 0:
                missing += 1
                fail[j] = np.nan
            else:
                fail[j] = nxt_worth[i]
        best = -np.inf
        act = 0
        for ju in range(up_n[t, p]):
            u = up_u[t, p, ju]
            if u < 0:
                for j in range(nm):
                    total = 0.0
                    total += 1.0 * fail[j]
                    if total > best:
                        best, act = total, mv_m[t, p, k, j]
                continue
            ps = up_ps[t, p, ju]
            won = (base & win_clear[u]) | win_set[u, p]
            if won != wlast[u]:
                wblocks[u], wlast[u] = lower_bound(nxt, 0, nxt.shape[0], won), won
            wblock = wblocks[u]
            for j in range(nm):
                i = index_of(nxt, wblock, span, won | mv_low[t, p, k, j])
                if i < 0:
                    missing += 1
                    continue
                total = 0.0
                if ps >= 1.0:
                    total += 1.0 * nxt_worth[i]
                else:
                    total += ps * nxt_worth[i]
                    total += (1.0 - ps) * fail[j]
                if total > best:
                    best, act = total, (u + 1) * 5 + mv_m[t, p, k, j]
        out_act[s] = act
        if with_reward:
            out_worth[s] = reward(keys[s], voi_model, voi, a_shift, a_mask, q_shift, q_mask) + best
        else:
            out_worth[s] = best
    return missing


@njit(cache=True)
def follow(layer, t, keys, act, mv_n, mv_m, mv_low, up_n, up_u, up_ps, win_clear, win_set, fields, out_act, out):
    """The optimal action of each state of ``layer`` (in slot t, any order; ``keys``/``act``:
    the slot's sorted layer and its actions) into ``out_act``, and its outcomes' next states,
    success first, into ``out``; returns how many (-1 if a state or its move is not found)."""
    c = 0
    for s in range(layer.shape[0]):
        key = layer[s]
        i = lower_bound(keys, 0, keys.shape[0], key)
        if i == keys.shape[0] or keys[i] != key:
            return -1
        code = np.int64(act[i])
        out_act[s] = act[i]
        u, m = code // 5 - 1, code % 5
        p, k = position(key, fields)
        low = -1
        for j in range(mv_n[t, p, k]):
            if mv_m[t, p, k, j] == m:
                low = mv_low[t, p, k, j]
        if low < 0:
            return -1
        base = aged(key, fields)
        ps = 0.0
        for ju in range(1, up_n[t, p]):
            if up_u[t, p, ju] == u:
                ps = up_ps[t, p, ju]
        if ps > 0.0:
            out[c] = ((base & win_clear[u]) | win_set[u, p]) | low
            c += 1
        if ps < 1.0:
            out[c] = base | low
            c += 1
    return c
