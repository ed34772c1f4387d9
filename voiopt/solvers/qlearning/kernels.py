"""Algorithm 1 compiled with numba: episodes of epsilon-greedy Q-learning over the hash
table of _qtable.py, and the greedy rollout of a trained table.

Training runs in chunks of whole episodes; between chunks Python grows the arrays when
needed, updates the progress bar and checks the stop rule. The key is updated in place each
step, not rebuilt.

A step waits on memory: with millions of states, the hash slot of s_{t+1} and the Q-values of
s_t are rarely in the CPU's caches. The random stream fixes every exploring step's action in
advance, so (without a mask) a cursor runs up to AHEAD slots ahead of the episode along its
exploring steps, prefetching the hash slot of each state it will reach, and AHEAD_POOL slots
ahead probes that slot (by then in cache) to prefetch the Q-value the step will update.
Prefetches are hints: the table, and so the plan, are the same without them.
"""

from __future__ import annotations

import numpy as np

from voiopt.mdp import robot as mdp_mod
from voiopt.objectives import Worth
from voiopt.runtime.jit import njit, prefetch
from voiopt.solvers.qlearning.rng import draw
from voiopt.solvers.qlearning.table import (
    ARG_BITS,
    ARG_MASK,
    QTable,
    encode_key,
    find,
    greedy_action,
    hand_back,
    home_slot,
    insert,
    room_for_episode,
    row_start,
)

AHEAD = 8  # slots the look-ahead cursor runs ahead of the episode
AHEAD_POOL = 3  # slots ahead where it prefetches the Q-value to update
RING = 16  # a power of two > AHEAD: the cursor's keys and actions by slot, modulo RING


@njit(cache=True, inline="always")
def set_field(k0, key, f, value, field_word, field_shift, clear):
    """Set packed field f to value in the key (k0 is its first word, kept in a register);
    returns the new first word."""
    v = np.uint64(value) << np.uint64(field_shift[f])
    w = field_word[f]
    if w == 0:
        return (k0 & clear[f]) | v
    key[w] = (key[w] & clear[f]) | v
    return k0


@njit(cache=True, inline="always")
def arrive(aoi, qidx, got, p):
    """One slot of the ages: every A_i + 1, then sensor ``got``'s update from point p arrives
    (A = 1, q = the index of p); ``got`` < 0: none arrives."""
    for i in range(aoi.shape[0]):
        aoi[i] += 1
    if got >= 0:
        aoi[got] = 1
        qidx[got] = 1 + p


@njit(cache=True, inline="always")
def slot_reward(aoi, qidx, voi_reward, aoi_reward):
    """min_i V_i(t+1), or -max_i A_i(t+1) with the AoI reward, before any idle penalty."""
    N = aoi.shape[0]
    if aoi_reward:
        worst = aoi[0]
        for i in range(1, N):
            if aoi[i] > worst:
                worst = aoi[i]
        return -float(worst)
    r = voi_reward[0, aoi[0], qidx[0]]
    for i in range(1, N):
        v = voi_reward[i, aoi[i], qidx[i]]
        if v < r:
            r = v
    return r


@njit(cache=True, inline="always")
def _feasible(p, k, t, moves, horizon, action_next, to_end, budget):
    """Action k at p in slot t leaves a way to end within the slots and moves left (MODEL.md
    section 9); every action is feasible in the last slot."""
    if t + 1 >= horizon:
        return True
    nxt = action_next[p, k]
    used = moves + (1 if nxt != p else 0)
    return used <= budget and to_end[nxt] <= min(horizon - 2 - t, budget - used)


@njit(cache=True)
def masked_best(pool, row, p, t, moves, n, horizon, action_next, to_end, budget):
    """(first feasible action of maximal Q-value, its value) in the Q row starting at pool[row]."""
    best_k = -1
    best = 0.0
    for j in range(n):
        if _feasible(p, j, t, moves, horizon, action_next, to_end, budget) and (best_k < 0 or pool[row + j] > best):
            best_k = j
            best = pool[row + j]
    return best_k, best


@njit(cache=True)
def masked_draw(x, p, t, moves, n, horizon, action_next, to_end, budget):
    """The action at uniform x in [0, 1) among the feasible ones, in action order."""
    nf = 0
    for j in range(n):
        if _feasible(p, j, t, moves, horizon, action_next, to_end, budget):
            nf += 1
    pick = int(x * nf)
    for j in range(n):
        if _feasible(p, j, t, moves, horizon, action_next, to_end, budget):
            if pick == 0:
                return j
            pick -= 1
    return -1


@njit(cache=True, nogil=True)
def _train(
    n_episodes, horizon, eps, eps0, beta, gamma, q_init, penalty, aoi_reward, slot_in_state,
    start, initial_aoi, n_actions, action_upload, action_next, voi_reward,
    field_word, field_shift, field_width, table, tablef, pool, counts, rng,
    masked, to_end, budget, lossy, succ,
):
    """Run up to n_episodes episodes; stop early (at an episode boundary) when the table could
    overflow during the next one. counts = [entries, pool used]; eps[0] and rng[0] are updated
    in place. Returns the number of episodes run.

    With ``lossy`` (MODEL.md section 11), a step that schedules sensor u from point p draws one
    more uniform x after its epsilon-greedy draws; the upload succeeds iff x < succ[p, u]. A
    failure leaves u as if unscheduled (its age grows, its q stays); the slot is used and the
    idle penalty does not apply (an upload was scheduled). Without ``lossy`` nothing is drawn,
    so the stream and the table are bit for bit those of the lossless model."""
    N = initial_aoi.shape[0]
    K = action_upload.shape[1]
    W = table.shape[1] - 2
    META, QMAX = W, W + 1
    aoi = np.empty(N, np.int64)
    qidx = np.empty(N, np.int64)
    # the packed key is updated in place each step: every age field +1 (and the slot field,
    # if in the state), then the new position and, on an upload, that sensor's two fields
    key0 = np.empty(W, np.uint64)
    encode_key(start, initial_aoi, np.zeros(N, np.int64), 0, 0, field_word, field_shift, key0)
    n_fields = field_word.shape[0]
    moves_field = n_fields > 2 * N + 2  # the moves made are part of the state
    key = np.empty(W, np.uint64)
    inc = np.zeros(W, np.uint64)
    for i in range(N):
        inc[field_word[1 + 2 * i]] += np.uint64(1) << np.uint64(field_shift[1 + 2 * i])
    if slot_in_state:
        inc[field_word[2 * N + 1]] += np.uint64(1) << np.uint64(field_shift[2 * N + 1])
    clear = np.empty(n_fields, np.uint64)  # ~(field mask) per field
    for f in range(n_fields):
        clear[f] = ~(((np.uint64(1) << np.uint64(field_width[f])) - np.uint64(1)) << np.uint64(field_shift[f]))
    ps, pclear = np.uint64(field_shift[0]), clear[0]  # the position is in word 0
    inc0 = inc[0]
    ahead = not masked and not lossy  # the look-ahead cursor (module docstring); it cannot replay outcome draws
    la_key = np.zeros(W, np.uint64)  # the cursor's key: la_k0, la_key[1:]
    ring_key = np.zeros((RING, W), np.uint64)
    ring_k = np.zeros(RING, np.int64)
    ring_tag = np.full(RING, -1, np.int64)

    bg = beta * gamma
    state, n_states, used = rng[0], counts[0], counts[1]
    ran = 0  # episodes run: all, or up to the first that might not fit
    while ran < n_episodes and room_for_episode(n_states, used, horizon, K, table, pool):
        p = start
        moves = 0
        for i in range(N):
            aoi[i] = initial_aoi[i]
            qidx[i] = 0
        k0 = key0[0]
        for w in range(1, W):
            key[w] = key0[w]
        cur, found = find(k0, key, table)
        if not found:
            used = insert(table, tablef, cur, k0, key, pool, used, n_actions[p], q_init)
            n_states += 1
        epsilon = eps[0]
        tag0 = ran * (horizon + 1)  # the ring's entries of this episode are tagged tag0 + slot
        cursor, stuck, la_k0, la_p, la_rng = -1, True, k0, p, state
        for t in range(horizon):
            # epsilon-greedy: x, and if exploring a second number for the action
            state, x = draw(state)
            if x < epsilon:
                state, x2 = draw(state)
                if masked:
                    k = masked_draw(x2, p, t, moves, n_actions[p], horizon, action_next, to_end, budget)
                else:
                    k = int(x2 * n_actions[p])
            elif masked:
                k, _ = masked_best(pool, row_start(table, cur), p, t, moves, n_actions[p], horizon, action_next, to_end, budget)
            else:
                k = greedy_action(table, cur)
            u = action_upload[p, k]
            p_next = action_next[p, k]
            got = u  # the sensor whose update arrives: u, unless its upload fails (docstring)
            if lossy and u >= 0:
                state, x = draw(state)
                if x >= succ[p, u]:
                    got = -1
            arrive(aoi, qidx, got, p)
            k0 += inc0
            for w in range(1, W):
                key[w] += inc[w]
            k0 = (k0 & pclear) | (np.uint64(p_next) << ps)
            if got >= 0:
                k0 = set_field(k0, key, 1 + 2 * got, 1, field_word, field_shift, clear)  # A_u = 1
                k0 = set_field(k0, key, 2 + 2 * got, 1 + p, field_word, field_shift, clear)  # q_u: from p
            if p_next != p:
                moves += 1
                if moves_field:
                    k0 = set_field(k0, key, 2 * N + 2, moves, field_word, field_shift, clear)
            if ahead:  # the look-ahead cursor (module docstring)
                if cursor <= t + 1:  # the episode has caught up: restart the cursor at s_{t+1}
                    cursor, stuck, la_k0, la_p, la_rng = t + 1, False, k0, p_next, state
                    for w in range(1, W):
                        la_key[w] = key[w]
                while not stuck and cursor < t + 1 + AHEAD and cursor < horizon:
                    la_rng, x = draw(la_rng)
                    if x >= epsilon:  # greedy: its action waits for the table
                        stuck = True
                        break
                    la_rng, x = draw(la_rng)
                    la_k = int(x * n_actions[la_p])
                    j = cursor & (RING - 1)
                    ring_k[j], ring_tag[j] = la_k, tag0 + cursor
                    ring_key[j, 0] = la_k0
                    for w in range(1, W):  # then the step's own key update, on the cursor's key
                        ring_key[j, w] = la_key[w]
                        la_key[w] += inc[w]
                    la_u, la_next = action_upload[la_p, la_k], action_next[la_p, la_k]
                    la_k0 = ((la_k0 + inc0) & pclear) | (np.uint64(la_next) << ps)
                    if la_u >= 0:
                        la_k0 = set_field(la_k0, la_key, 1 + 2 * la_u, 1, field_word, field_shift, clear)
                        la_k0 = set_field(la_k0, la_key, 2 + 2 * la_u, 1 + la_p, field_word, field_shift, clear)
                    la_p = la_next
                    cursor += 1
                    prefetch(table, home_slot(la_k0, la_key, table))
                j = (t + 1 + AHEAD_POOL) & (RING - 1)
                if ring_tag[j] == tag0 + t + 1 + AHEAD_POOL:  # its hash slot was prefetched a few steps ago
                    s2, f2 = find(ring_key[j, 0], ring_key[j], table)
                    if f2:
                        prefetch(pool, row_start(table, s2) + ring_k[j])
            r = slot_reward(aoi, qidx, voi_reward, aoi_reward)
            if u < 0:
                r = r - penalty
            # find s_{t+1}; store it unless it is s_T (never acted in)
            nxt, found = find(k0, key, table)
            if found and masked and t + 1 < horizon:  # the best feasible action of s_{t+1}
                _, future = masked_best(pool, row_start(table, nxt), p_next, t + 1, moves, n_actions[p_next], horizon, action_next,
                                         to_end, budget)
            elif found:
                future = tablef[nxt, QMAX]
                if ahead:  # the Q-value step t + 1 will update, when its action is known
                    j = (t + 1) & (RING - 1)
                    if ring_tag[j] == tag0 + t + 1:
                        prefetch(pool, row_start(table, nxt) + ring_k[j])
                    elif stuck and cursor == t + 1:
                        prefetch(pool, row_start(table, nxt) + greedy_action(table, nxt))
            else:
                future = q_init
                if t + 1 < horizon:
                    used = insert(table, tablef, nxt, k0, key, pool, used, n_actions[p_next], q_init)
                    n_states += 1
            # Q(s_t, k) and the cached first maximum of s_t
            meta = table[cur, META]
            row = np.int64(meta >> ARG_BITS) - 1
            v = (1.0 - beta) * pool[row + k] + beta * r + bg * future
            pool[row + k] = v
            a = np.int64(meta & ARG_MASK)
            best = tablef[cur, QMAX]
            if k == a:
                if v >= best:
                    tablef[cur, QMAX] = v
                else:
                    a = 0
                    best = pool[row]
                    for j in range(1, n_actions[p]):
                        if pool[row + j] > best:
                            best = pool[row + j]
                            a = j
                    table[cur, META] = (meta & ~ARG_MASK) | np.uint64(a)
                    tablef[cur, QMAX] = best
            elif v > best or (v == best and k < a):
                table[cur, META] = (meta & ~ARG_MASK) | np.uint64(k)
                tablef[cur, QMAX] = v
            p = p_next
            cur = nxt
        eps[0] = eps[0] - eps0
        ran += 1
    hand_back(rng, state, counts, n_states, used)
    return ran


@njit(cache=True)
def _rollout(horizon, slot_in_state, start, initial_aoi, n_actions, action_upload, action_next,
             field_word, field_shift, table, pool, masked, to_end, budget):
    """The greedy plan of the table: first maximal action in each state (action 0 if unseen);
    with a mask, the first maximal feasible one (the first feasible one if unseen)."""
    N = initial_aoi.shape[0]
    W = table.shape[1] - 2
    aoi = initial_aoi.copy()
    qidx = np.zeros(N, np.int64)
    key = np.empty(W, np.uint64)
    idx = np.empty(horizon, np.int64)
    sched = np.empty(horizon, np.int64)
    p = start
    moves = 0
    for t in range(horizon):
        encode_key(p, aoi, qidx, t * slot_in_state, moves, field_word, field_shift, key)
        s, found = find(key[0], key, table)
        if masked:
            if found:
                k, _ = masked_best(pool, row_start(table, s), p, t, moves, n_actions[p], horizon, action_next, to_end, budget)
            else:
                k = masked_draw(0.0, p, t, moves, n_actions[p], horizon, action_next, to_end, budget)
        else:
            k = greedy_action(table, s) if found else 0
        u = action_upload[p, k]
        idx[t] = p
        sched[t] = u
        arrive(aoi, qidx, u, p)
        if action_next[p, k] != p:
            moves += 1
        p = action_next[p, k]
    return idx, sched


NO_LINKS = np.ones((1, 1))  # _train's success table where no outcome is drawn (never read)


def train(model: mdp_mod.MDP, table: QTable, n_episodes: int, eps: np.ndarray, eps0: float,
          beta: float, gamma: float, rng: np.ndarray, succ: np.ndarray | None = None) -> tuple[int, bool]:
    """Run n_episodes of Algorithm 1, growing the table as needed; with ``succ`` (lattice
    points x sensors, voiopt.core.links.success_table) each upload's outcome is drawn.
    Returns (episodes run, False if stopped by the memory limit)."""
    return table.run(n_episodes, lambda n: _train(
        n, model.horizon, eps, eps0, beta, gamma, table.q_init, model.penalty,
        model.reward == Worth.AOI, int(model.slot_in_state), model.start, model.initial_aoi, model.n_actions,
        model.action_upload, model.action_next, model.voi_reward, model.field_word,
        model.field_shift, model.field_width, table.table, table.table.view(np.float64), table.pool,
        table.counts, rng, model.masked, model.to_end, model.budget, succ is not None,
        NO_LINKS if succ is None else succ,
    ))


@njit(cache=True)
def _lookup(key, table):
    """The pool row of the state with packed ``key`` in the table, or -1 if it was never visited."""
    s, found = find(key[0], key, table)
    return row_start(table, s) if found else -1


def q_row(model: mdp_mod.MDP, table: QTable, state) -> np.ndarray | None:
    """The Q-values of a state's actions (mdp.MDP's state tuple), or None if never visited."""
    r = _lookup(model.encode(state), table.table)
    return None if r < 0 else table.pool[r: r + int(model.n_actions[state[0]])]


def rollout(model: mdp_mod.MDP, table: QTable) -> tuple[np.ndarray, np.ndarray]:
    """(point indices, schedule with -1) of the greedy plan of the table."""
    return _rollout(
        model.horizon, int(model.slot_in_state), model.start, model.initial_aoi, model.n_actions, model.action_upload,
        model.action_next, model.field_word, model.field_shift, table.table, table.pool, model.masked, model.to_end,
        model.budget,
    )
