"""Algorithm 1 for several robots (MODEL.md section 10), compiled: the joint state and the joint
action of models/fleet_mdp.py over the hash table of _qtable.py.

A simpler kernel than the one-robot one: each step enumerates the legal joint actions of the
state (conflicts between robots and the joint mask ``alive``) in ascending order, draws among
them when exploring, and takes the first maximal Q among them when greedy; the bootstrap is the
maximum over the next state's legal joint actions, and those are the next step's choices. The
key is packed afresh each step. fleet_reference.py is the same algorithm in plain Python, and
the tests require the same table and plan bit for bit.
"""

from __future__ import annotations

import numpy as np

from voiopt.mdp import fleet as fleet_mdp
from voiopt.objectives import Worth
from voiopt.runtime.jit import njit
from voiopt.solvers.qlearning.kernels import slot_reward
from voiopt.solvers.qlearning.rng import draw
from voiopt.solvers.qlearning.table import (
    QTable,
    find,
    hand_back,
    insert,
    room_for_episode,
    row_start,
)

FLEET_SLOTS = 1 << 10  # the first hash table of a fleet: joint rows are long, so start small


@njit(cache=True)
def _joint_count(points, n_actions):
    J = 1
    for k in range(points.shape[0]):
        J *= n_actions[points[k]]
    return J


@njit(cache=True)
def _split(j, points, n_actions, action_upload, action_next, nxt, up):
    """Robot by robot, the next point and the upload of joint action j (robot 0 most significant)."""
    for k in range(points.shape[0] - 1, -1, -1):
        n = n_actions[points[k]]
        a = j % n
        j //= n
        nxt[k] = action_next[points[k], a]
        up[k] = action_upload[points[k], a]


@njit(cache=True)
def _legal(points, moves, t, horizon, n_actions, action_upload, action_next, masked, alive, first, radix,
           counted, budgets, out, nxt, up):
    """Write the legal joint actions of slot t, ascending, to out; return how many."""
    K = points.shape[0]
    n_points = n_actions.shape[0]
    count = 0
    for j in range(_joint_count(points, n_actions)):
        _split(j, points, n_actions, action_upload, action_next, nxt, up)
        ok = True
        for k in range(1, K):
            for i in range(k):
                if nxt[k] == nxt[i] or (nxt[k] == points[i] and nxt[i] == points[k]) or (up[k] >= 0 and up[k] == up[i]):
                    ok = False
        if ok and masked and t + 1 < horizon:
            c = 0
            mi = 0
            for k in range(K):
                c = c * n_points + nxt[k]
                m = 0
                if counted[k]:
                    m = moves[k] + (1 if nxt[k] != points[k] else 0)
                    if m > budgets[k]:
                        ok = False
                mi = mi * radix[k] + m
            if ok and alive[max(t + 1 - first, 0), c, mi] == 0:
                ok = False
        if ok:
            out[count] = j
            count += 1
    return count


@njit(cache=True)
def _key(points, aoi, qidx, slot, moves, counted, field_word, field_shift, key):
    """Pack the state's fields (points, then A_i and q_i, the slot, the counted moves) into key."""
    key[:] = 0
    K, N = points.shape[0], aoi.shape[0]
    f = 0
    for k in range(K):
        key[field_word[f]] |= np.uint64(points[k]) << np.uint64(field_shift[f])
        f += 1
    for i in range(N):
        key[field_word[f]] |= np.uint64(aoi[i]) << np.uint64(field_shift[f])
        key[field_word[f + 1]] |= np.uint64(qidx[i]) << np.uint64(field_shift[f + 1])
        f += 2
    key[field_word[f]] |= np.uint64(slot) << np.uint64(field_shift[f])
    f += 1
    for k in range(K):
        if counted[k]:
            key[field_word[f]] |= np.uint64(moves[k]) << np.uint64(field_shift[f])
            f += 1


@njit(cache=True)
def _first_max(pool, row, legal, n_legal):
    """(the first legal joint action of maximal Q, its Q) in the row at pool[row]."""
    best_k = legal[0]
    best = pool[row + best_k]
    for i in range(1, n_legal):
        v = pool[row + legal[i]]
        if v > best:
            best, best_k = v, legal[i]
    return best_k, best


@njit(cache=True)
def _advance(points, moves, aoi, qidx, nxt, up, counted):
    """One slot of section 10 in place; returns how many robots upload nothing."""
    idle = 0
    for i in range(aoi.shape[0]):
        aoi[i] += 1
    for k in range(points.shape[0]):
        if up[k] >= 0:
            aoi[up[k]] = 1
            qidx[up[k]] = 1 + points[k]
        else:
            idle += 1
        if counted[k] and nxt[k] != points[k]:
            moves[k] += 1
        points[k] = nxt[k]
    return idle


@njit(cache=True, nogil=True)
def _train(n_episodes, horizon, eps, eps0, beta, gamma, q_init, penalty, aoi_reward, slot_in_state,
           starts, initial_aoi, n_actions, action_upload, action_next, voi_reward, field_word, field_shift,
           table, tablef, pool, counts, rng, masked, alive, first, radix, counted, budgets, max_joint):
    """Run up to n_episodes episodes; stop early (at an episode boundary) when the table could
    overflow during the next one. Returns the number of episodes run."""
    K, N = starts.shape[0], initial_aoi.shape[0]
    W = table.shape[1] - 2
    bg = beta * gamma
    legal, legal_next = np.empty(max_joint, np.int64), np.empty(max_joint, np.int64)
    points, moves = np.empty(K, np.int64), np.zeros(K, np.int64)
    nxt, up = np.empty(K, np.int64), np.empty(K, np.int64)
    aoi, qidx = np.empty(N, np.int64), np.empty(N, np.int64)
    key = np.empty(W, np.uint64)
    state, n_states, used = rng[0], counts[0], counts[1]
    ran = 0  # episodes run: all, or up to the first that might not fit
    while ran < n_episodes and room_for_episode(n_states, used, horizon, max_joint, table, pool):
        ran += 1
        for k in range(K):
            points[k], moves[k] = starts[k], 0
        for i in range(N):
            aoi[i], qidx[i] = initial_aoi[i], 0
        _key(points, aoi, qidx, 0, moves, counted, field_word, field_shift, key)
        cur, found = find(key[0], key, table)
        if not found:
            J = _joint_count(points, n_actions)
            used = insert(table, tablef, cur, key[0], key, pool, used, J, q_init)
            n_states += 1
        n_legal = _legal(points, moves, 0, horizon, n_actions, action_upload, action_next, masked, alive, first, radix,
                         counted, budgets, legal, nxt, up)
        epsilon = eps[0]
        for t in range(horizon):
            row = row_start(table, cur)
            state, x = draw(state)
            if x < epsilon:
                state, x2 = draw(state)
                k = legal[int(x2 * n_legal)]
            else:
                k, _ = _first_max(pool, row, legal, n_legal)
            _split(k, points, n_actions, action_upload, action_next, nxt, up)
            idle = _advance(points, moves, aoi, qidx, nxt, up, counted)
            r = slot_reward(aoi, qidx, voi_reward, aoi_reward) - penalty * idle
            _key(points, aoi, qidx, (t + 1) * slot_in_state, moves, counted, field_word, field_shift, key)
            nxt_slot, found = find(key[0], key, table)
            n_next = _legal(points, moves, t + 1, horizon, n_actions, action_upload, action_next, masked, alive, first,
                            radix, counted, budgets, legal_next, nxt, up)
            if found:
                _, future = _first_max(pool, row_start(table, nxt_slot), legal_next, n_next)
            else:
                future = q_init
                if t + 1 < horizon:
                    J = _joint_count(points, n_actions)
                    used = insert(table, tablef, nxt_slot, key[0], key, pool, used, J, q_init)
                    n_states += 1
            pool[row + k] = (1.0 - beta) * pool[row + k] + beta * r + bg * future
            cur = nxt_slot
            legal, legal_next = legal_next, legal
            n_legal = n_next
        eps[0] = eps[0] - eps0
    hand_back(rng, state, counts, n_states, used)
    return ran


@njit(cache=True)
def _rollout(horizon, slot_in_state, starts, initial_aoi, n_actions, action_upload, action_next, field_word,
             field_shift, table, pool, masked, alive, first, radix, counted, budgets, max_joint):
    """The greedy plan: the first maximal legal joint action (the first legal one if unseen)."""
    K, N = starts.shape[0], initial_aoi.shape[0]
    W = table.shape[1] - 2
    legal = np.empty(max_joint, np.int64)
    points, moves = starts.copy(), np.zeros(K, np.int64)
    nxt, up = np.empty(K, np.int64), np.empty(K, np.int64)
    aoi, qidx = initial_aoi.copy(), np.zeros(N, np.int64)
    key = np.empty(W, np.uint64)
    idx, sched = np.empty((K, horizon), np.int64), np.empty((K, horizon), np.int64)
    for t in range(horizon):
        n_legal = _legal(points, moves, t, horizon, n_actions, action_upload, action_next, masked, alive, first, radix,
                         counted, budgets, legal, nxt, up)
        _key(points, aoi, qidx, t * slot_in_state, moves, counted, field_word, field_shift, key)
        s, found = find(key[0], key, table)
        k = legal[0]
        if found:
            k, _ = _first_max(pool, row_start(table, s), legal, n_legal)
        _split(k, points, n_actions, action_upload, action_next, nxt, up)
        for r in range(K):
            idx[r, t], sched[r, t] = points[r], up[r]
        _advance(points, moves, aoi, qidx, nxt, up, counted)
    return idx, sched


def _arrays(model: fleet_mdp.FleetMDP) -> tuple:
    one = model.one
    return (model.starts, one.initial_aoi, one.n_actions, one.action_upload, one.action_next)


def _masks(model: fleet_mdp.FleetMDP) -> tuple:
    return (model.masked, model.alive, model.alive_first, model.moves_radix, model.counted, model.budgets, model.max_actions)


def train(model: fleet_mdp.FleetMDP, table: QTable, n_episodes: int, eps: np.ndarray, eps0: float,
          beta: float, gamma: float, rng: np.ndarray) -> tuple[int, bool]:
    """Run n_episodes of Algorithm 1 on the joint MDP, growing the table as needed.
    Returns (episodes run, False if stopped by the memory limit)."""
    one = model.one
    return table.run(n_episodes, lambda n: _train(
        n, model.horizon, eps, eps0, beta, gamma, table.q_init, one.penalty, one.reward == Worth.AOI,
        int(one.slot_in_state), *_arrays(model), one.voi_reward, model.field_word, model.field_shift,
        table.table, table.table.view(np.float64), table.pool, table.counts, rng, *_masks(model),
    ))


def rollout(model: fleet_mdp.FleetMDP, table: QTable) -> tuple[np.ndarray, np.ndarray]:
    """((K, T) point indices, (K, T) schedule with -1) of the greedy joint plan."""
    return _rollout(model.horizon, int(model.one.slot_in_state), *_arrays(model), model.field_word, model.field_shift,
                    table.table, table.pool, *_masks(model))


def to_dict(model: fleet_mdp.FleetMDP, table: QTable) -> dict[tuple, list[float]]:
    """{joint state: Q-values of its joint actions}, for tests and inspection."""
    return table.to_dict(lambda state: model.joint_count(state[0]))
