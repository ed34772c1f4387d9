"""Algorithm 1 in plain Python: the reference the compiled kernel must reproduce bit for bit.

A dict keyed by state tuples holds one list of Q-values per state (its feasible actions, in the
order of voiopt/mdp/robot.py); random numbers are the same splitmix64 stream as the kernel's.
Used by tests/solvers/test_qlearning.py and benchmarks/qlearning_speed.py: the readable
statement of what the kernels compute. With an end or a budget (MODEL.md section 9), actions
that leave no way to end are masked: exploration draws among the feasible ones, and the greedy
choice and the bootstrap maximum range over them.
"""

from __future__ import annotations

import numpy as np

_M64 = (1 << 64) - 1


class SplitMix64:
    def __init__(self, seed: int):
        self.state = seed & _M64

    def uniform(self) -> float:
        self.state = (self.state + 0x9E3779B97F4A7C15) & _M64
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _M64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _M64
        z ^= z >> 31
        return (z >> 11) * (1.0 / 9007199254740992.0)


def first_max(q, allowed):
    """The first action of maximal Q-value among the allowed ones (ascending)."""
    return max(allowed, key=lambda j: (q[j], -j))


def epsilon_greedy(rng, eps: float, q, allowed):
    """Algorithm 1's choice: with probability eps a uniform allowed action, else the first of
    maximal Q (two uniforms when exploring, one otherwise, as the kernels draw them)."""
    if rng.uniform() < eps:
        return allowed[int(rng.uniform() * len(allowed))]
    return first_max(q, allowed)


def reference_qlearning(model, episodes: int, seed: int = 0, beta: float = 0.75, gamma: float = 0.9,
                        q_init: float = 0.0):
    """Run Algorithm 1 on an voiopt.mdp.robot.MDP; return (Q dict, point indices, schedule)."""
    rng = SplitMix64(seed)
    T = model.horizon
    Q: dict = {}
    eps, eps0 = 1.0, 1.0 / episodes

    def row(state):
        if state not in Q:
            Q[state] = [q_init] * int(model.n_actions[state[0]])
        return Q[state]

    def feasible(state, t, q):  # the paper's model needs no mask: every action, at no cost
        return range(len(q)) if not model.masked else np.flatnonzero(model.feasible(state, t)).tolist()

    for _ in range(episodes):
        state = model.initial_state()
        q = row(state)
        for t in range(T):
            k = epsilon_greedy(rng, eps, q, feasible(state, t, q))
            nxt, r = model.step(state, k)
            if t + 1 < T:
                q_next = row(nxt)
                future = max(q_next[j] for j in feasible(nxt, t + 1, q_next))
            else:
                future = max(Q[nxt]) if nxt in Q else q_init
                q_next = None
            q[k] = (1.0 - beta) * q[k] + beta * r + beta * gamma * future
            state, q = nxt, q_next
        eps = eps - eps0

    idx, sched = [], []
    state = model.initial_state()
    for t in range(T):
        q = Q.get(state)
        allowed = feasible(state, t, q or [0] * int(model.n_actions[state[0]]))
        k = allowed[0] if q is None else first_max(q, allowed)
        idx.append(state[0])
        sched.append(int(model.action_upload[state[0], k]))
        state, _ = model.step(state, k)
    return Q, idx, sched


def reference_fleet_qlearning(model, episodes: int, seed: int = 0, beta: float = 0.75, gamma: float = 0.9,
                              q_init: float = 0.0):
    """Algorithm 1 on a voiopt.mdp.fleet.FleetMDP (MODEL.md section 10): one list of
    Q-values per joint state, one per joint action number; exploration draws among the legal
    joint actions, the greedy choice and the bootstrap range over them. Returns (Q dict,
    (K, T) point indices, (K, T) schedule), what the compiled _fleet.py must reproduce."""
    rng, T, Q = SplitMix64(seed), model.horizon, {}
    eps, eps0 = 1.0, 1.0 / episodes
    for _ in range(episodes):
        state = model.initial_state()
        q = Q.setdefault(state, [q_init] * model.joint_count(state[0]))
        for t in range(T):
            k = epsilon_greedy(rng, eps, q, model.legal(state, t))
            nxt, r = model.step(state, k)
            if t + 1 < T:
                q_next = Q.setdefault(nxt, [q_init] * model.joint_count(nxt[0]))
            else:
                q_next = Q.get(nxt)
            if q_next is None:
                future = q_init
            else:
                future = max(q_next[j] for j in model.legal(nxt, t + 1))
            q[k] = (1.0 - beta) * q[k] + beta * r + beta * gamma * future
            state, q = nxt, q_next
        eps = eps - eps0

    K = model.n_robots
    idx, sched = [[] for _ in range(K)], [[] for _ in range(K)]
    state = model.initial_state()
    for t in range(T):
        allowed = model.legal(state, t)
        q = Q.get(state)
        k = allowed[0] if q is None else first_max(q, allowed)
        for r, (p, a) in enumerate(zip(state[0], model.split(state[0], k), strict=True)):
            idx[r].append(p)
            sched[r].append(int(model.one.action_upload[p, a]))
        state, _ = model.step(state, k)
    return Q, idx, sched
