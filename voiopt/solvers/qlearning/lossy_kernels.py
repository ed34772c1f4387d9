"""Algorithm 1 under lossy links (MODEL.md section 11), compiled with numba: the episodes of
kernels._train, with each upload's outcome drawn from the same splitmix64 stream.

After the epsilon-greedy draws of a step, a step that schedules sensor u from point p draws
one more uniform x; the upload succeeds iff x < succ[p, u] (the links' success table). A
failure leaves u as if unscheduled (its age grows, its q stays); the slot is used and the idle
penalty does not apply (an upload was scheduled). Only lossy instances come here: without
links, or with every probability 1, Q-learning runs kernels._train untouched and draws no
outcome, so its stream and results are bit for bit as before. This kernel has no look-ahead
prefetch cursor (the outcome draws would have to be replayed ahead of the episode).
"""

from __future__ import annotations

import numpy as np

from voiopt.objectives import Worth
from voiopt.runtime.jit import njit
from voiopt.solvers.qlearning.kernels import masked_best, masked_draw, set_field, slot_reward
from voiopt.solvers.qlearning.rng import GOLDEN, S11, TWO_M53, mix
from voiopt.solvers.qlearning.table import (
    ARG_BITS,
    ARG_MASK,
    encode_key,
    find,
    greedy_action,
    insert,
    room_for_episode,
    row_start,
)


@njit(cache=True, nogil=True)
def _train_lossy(
    n_episodes, horizon, eps, eps0, beta, gamma, q_init, penalty, aoi_reward, slot_in_state,
    start, initial_aoi, n_actions, action_upload, action_next, voi_reward,
    field_word, field_shift, field_width, table, tablef, pool, counts, rng,
    masked, to_end, budget, succ,
):
    """As kernels._train, with outcomes drawn; returns the number of episodes run."""
    N = initial_aoi.shape[0]
    K = action_upload.shape[1]
    W = table.shape[1] - 2
    META, QMAX = W, W + 1
    aoi = np.empty(N, np.int64)
    qidx = np.empty(N, np.int64)
    key0 = np.empty(W, np.uint64)
    encode_key(start, initial_aoi, np.zeros(N, np.int64), 0, 0, field_word, field_shift, key0)
    n_fields = field_word.shape[0]
    moves_field = n_fields > 2 * N + 2
    key = np.empty(W, np.uint64)
    inc = np.zeros(W, np.uint64)
    for i in range(N):
        inc[field_word[1 + 2 * i]] += np.uint64(1) << np.uint64(field_shift[1 + 2 * i])
    if slot_in_state:
        inc[field_word[2 * N + 1]] += np.uint64(1) << np.uint64(field_shift[2 * N + 1])
    clear = np.empty(n_fields, np.uint64)
    for f in range(n_fields):
        clear[f] = ~(((np.uint64(1) << np.uint64(field_width[f])) - np.uint64(1)) << np.uint64(field_shift[f]))
    ps, pclear = np.uint64(field_shift[0]), clear[0]
    inc0 = inc[0]
    bg = beta * gamma
    state = rng[0]
    n_states, used = counts[0], counts[1]
    for ep in range(n_episodes):
        if not room_for_episode(n_states, used, horizon, K, table, pool):
            rng[0] = state
            counts[0], counts[1] = n_states, used
            return ep
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
            insert(table, tablef, cur, k0, key, pool, used, n_actions[p], q_init)
            n_states += 1
            used += n_actions[p]
        epsilon = eps[0]
        for t in range(horizon):
            state += GOLDEN
            x = float(mix(state) >> S11) * TWO_M53
            if x < epsilon:
                state += GOLDEN
                x2 = float(mix(state) >> S11) * TWO_M53
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
            ok = False
            if u >= 0:  # the outcome: U < p_u(d)
                state += GOLDEN
                ok = float(mix(state) >> S11) * TWO_M53 < succ[p, u]
            for i in range(N):
                aoi[i] += 1
            if ok:
                aoi[u] = 1
                qidx[u] = 1 + p
            k0 += inc0
            for w in range(1, W):
                key[w] += inc[w]
            k0 = (k0 & pclear) | (np.uint64(p_next) << ps)
            if ok:
                k0 = set_field(k0, key, 1 + 2 * u, 1, field_word, field_shift, clear)
                k0 = set_field(k0, key, 2 + 2 * u, 1 + p, field_word, field_shift, clear)
            if p_next != p:
                moves += 1
                if moves_field:
                    k0 = set_field(k0, key, 2 * N + 2, moves, field_word, field_shift, clear)
            r = slot_reward(aoi, qidx, voi_reward, aoi_reward)
            if u < 0:
                r = r - penalty
            nxt, found = find(k0, key, table)
            if found and masked and t + 1 < horizon:
                _, future = masked_best(pool, row_start(table, nxt), p_next, t + 1, moves, n_actions[p_next], horizon,
                                         action_next, to_end, budget)
            elif found:
                future = tablef[nxt, QMAX]
            else:
                future = q_init
                if t + 1 < horizon:
                    insert(table, tablef, nxt, k0, key, pool, used, n_actions[p_next], q_init)
                    n_states += 1
                    used += n_actions[p_next]
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
    rng[0] = state
    counts[0], counts[1] = n_states, used
    return n_episodes


@njit(cache=True)
def _lookup(key, table):
    """The pool row of the state with packed ``key`` in the table, or -1 if it was never visited."""
    s, found = find(key[0], key, table)
    return row_start(table, s) if found else -1


def q_row(model, table, state) -> np.ndarray | None:
    """The Q-values of a state's actions (mdp.MDP's state tuple), or None if never visited."""
    r = _lookup(model.encode(state), table.table)
    return None if r < 0 else table.pool[r: r + int(model.n_actions[state[0]])]


def train_lossy(model, table, n_episodes: int, eps: np.ndarray, eps0: float, beta: float, gamma: float,
                rng: np.ndarray, succ: np.ndarray) -> tuple[int, bool]:
    """Run n_episodes of Algorithm 1 with outcomes drawn, growing the table as needed."""
    return table.run(n_episodes, lambda n: _train_lossy(
        n, model.horizon, eps, eps0, beta, gamma, table.q_init, model.penalty,
        model.reward == Worth.AOI, int(model.slot_in_state), model.start, model.initial_aoi, model.n_actions,
        model.action_upload, model.action_next, model.voi_reward, model.field_word,
        model.field_shift, model.field_width, table.table, table.table.view(np.float64), table.pool,
        table.counts, rng, model.masked, model.to_end, model.budget, succ,
    ))
