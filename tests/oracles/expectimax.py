"""Tiny lossy instances and an exhaustive expectimax over (slot, position, moves used, A, q),
written from MODEL.md sections 1-5, 9 and 11 alone (nothing of voiopt's): the oracle of the
optimal policy's value."""

from __future__ import annotations

import functools
import math

import numpy as np

MOVES = [(0, 0), (0, 1), (0, -1), (1, 0), (-1, 0)]


def tiny(seed: int, n: int, T: int, links: dict | None, **extra) -> dict:
    rng = np.random.default_rng(seed)
    sensors = []
    for _ in range(n):
        s = {"position": [float(rng.uniform(0, 2)), float(rng.uniform(0, 2))], "rho": float(rng.uniform(0.3, 0.9)),
             "initial_aoi": int(rng.integers(1, 4)), "initial_distance": float(rng.uniform(0.2, 1.0))}
        sensors.append(s)
    d = {"name": f"tiny{seed}", "area": {"width": 2, "height": 2}, "horizon": T,
         "start": [int(rng.integers(0, 3)), int(rng.integers(0, 3))], "sensors": sensors, **extra}
    if links is not None:
        d["links"] = links
    return d


def oracle(d: dict, objective: str) -> float:
    """Exhaustive expectimax over (slot, position, moves, A, q), from MODEL.md sections 1-5, 9, 11."""
    W, H, T = d["area"]["width"], d["area"]["height"], d["horizon"]
    ch = {"g0_db": -50.0, "bandwidth_hz": 2e6, "noise_dbm_per_hz": -110.0, "d_th": 1.0}
    g0, B = 10 ** (ch["g0_db"] / 10), ch["bandwidth_hz"]
    N0 = 10 ** (ch["noise_dbm_per_hz"] / 10) / 1000
    S = d["sensors"]
    links = d.get("links")
    end = tuple(d["end"]) if "end" in d else None
    budget = d.get("max_moves")

    def dist(pos, i):
        return math.hypot(pos[0] - S[i]["position"][0], pos[1] - S[i]["position"][1])

    def prob(i, dd):
        if links is None:
            return 1.0
        if "success" in S[i]:
            return S[i]["success"]
        if links["model"] == "bernoulli":
            return links["success"]
        gamma = 10 ** (links["snr_threshold_db"] / 10)
        return math.exp(-gamma * B * N0 * dd * dd / (S[i].get("power_w", 1.0) * g0))

    def voi(i, a, q):
        P = S[i].get("power_w", 1.0)
        x = P * g0 * S[i]["rho"] ** a / (B * N0 * q * q + P * g0)
        return -B * math.log1p(-x) / math.log(2)

    def reward(A, q):
        if objective == "mean-max-aoi":
            return -max(A)
        return min(voi(i, A[i], q[i]) for i in range(len(S)))

    def ok(pos, t, moves):
        if not (0 <= pos[0] <= W and 0 <= pos[1] <= H):
            return False
        if budget is not None and moves > budget:
            return False
        if end is not None:
            need = abs(pos[0] - end[0]) + abs(pos[1] - end[1])
            left = T - 1 - t if budget is None else min(T - 1 - t, budget - moves)
            return need <= left
        return True

    @functools.cache
    def best(t, pos, moves, A, q):
        if t == T:
            return 0.0
        out = -math.inf
        for u in [None] + [i for i in range(len(S)) if dist(pos, i) <= 1.0 + 1e-9]:
            for mv in MOVES if t < T - 1 else [(0, 0)]:
                nxt = (pos[0] + mv[0], pos[1] + mv[1])
                m2 = moves + (mv != (0, 0))
                if t < T - 1 and not ok(nxt, t + 1, m2):
                    continue
                A2 = tuple(a + 1 for a in A)
                branches = [(1.0, A2, q)]
                if u is not None:
                    p = prob(u, dist(pos, u))
                    As = tuple(1 if i == u else a for i, a in enumerate(A2))
                    qs = tuple(dist(pos, u) if i == u else x for i, x in enumerate(q))
                    branches = [(p, As, qs), (1.0 - p, A2, q)]
                v = sum(pr * (reward(a2, q2) + best(t + 1, nxt, m2, a2, q2)) for pr, a2, q2 in branches if pr > 0)
                out = max(out, v)
        return out

    A0 = tuple(s["initial_aoi"] for s in S)
    q0 = tuple(s["initial_distance"] for s in S)
    total = best(0, tuple(d["start"]), 0, A0, q0) / T
    return total if objective == "mean-min-voi" else -total
