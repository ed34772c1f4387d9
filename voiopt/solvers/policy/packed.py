"""The observed state of one robot (voiopt.core.steps) packed into one int64 key, and the rules
of its slots as arrays, for the compiled layered expectimax (``kernels.py``, ``layered.py``).

A key's bit fields, from the lowest: the point index, the moves used (only where ``max_moves``
is set), then for each sensor i its age A_i and, for the VoI objective, its distance q_i as an
index into i's table of distances (its initial distance, then dist[i, p] for each point p in
its range, by point; a distance equal to an earlier one takes its index, so two keys are equal
exactly where the two state tuples are). An age is at most the initial age + T. The position
fields sit lowest so that the states of one slot that share their ages and distances are
neighbours in sorted order. ``Packing.fits`` says whether every field fits 63 bits.

The rules come from Steps alone (``moves``, ``uploads``, ``voi``), tabulated over the slots,
points and moves used that a plan can reach: the kernels follow the same rules as the plain
expectimax, in the same order.
"""

from __future__ import annotations

import numpy as np

from voiopt.core.steps import Steps
from voiopt.runtime.stop import Stop, halt_if_asked

KEY_BITS = 63  # a key stays a non-negative int64
MAX_CELLS = 1 << 20  # entries of the moves' tables (slot, point, moves used) or the VoI table, at most


class Packing:
    """The bit fields of a key and the rules' tables, for one robot's Steps."""

    def __init__(self, steps: Steps) -> None:
        self.steps = steps
        inst, lat, N, T = steps.instance, steps.lat, steps.N, steps.T
        self.N, self.T, self.voi = N, T, steps.voi_model
        self.max_k = int(lat.budget) if steps.budgeted else 0
        self.initial_age = [s.initial_aoi for s in inst.sensors]
        self.distances: list[list[float]] = []  # sensor i's table of distances (VoI only)
        self.qidx = np.zeros((N, lat.n_points), dtype=np.int64)  # index of dist[i, p] in i's table
        for i in range(N if self.voi else 0):
            table = [inst.initial_distance(i)]
            for p in np.flatnonzero(lat.in_range[i]):
                q = float(steps.dist[i, p])
                if q not in table:
                    table.append(q)
                self.qidx[i, p] = table.index(q)
            self.distances.append(table)
        widths = [max(lat.n_points - 1, 0).bit_length(), self.max_k.bit_length()]
        for i in range(N):
            widths.append((self.initial_age[i] + T).bit_length())
            widths.append((len(self.distances[i]) - 1).bit_length() if self.voi else 0)
        shifts = np.concatenate([[0], np.cumsum(widths)[:-1]]).astype(np.int64)
        self.bits = int(sum(widths))
        voi_cells = N * (max(self.initial_age) + T + 1) * max(map(len, self.distances)) if self.voi else 0
        self.cells = max(T * lat.n_points * (self.max_k + 1), voi_cells)  # of the moves' tables, of the VoI table
        self.fits = self.bits <= KEY_BITS and self.cells <= MAX_CELLS and 5 * N + 4 <= 255  # an action is a uint8
        self.k_shift = int(shifts[1])
        self.low_bits = int(shifts[2])  # the position fields: point and moves used
        self.p_mask = (1 << widths[0]) - 1
        self.k_mask = (1 << widths[1]) - 1
        self.a_shift, self.q_shift = shifts[2::2].copy(), shifts[3::2].copy()
        self.a_mask = np.array([(1 << w) - 1 for w in widths[2::2]], dtype=np.int64)
        self.q_mask = np.array([(1 << w) - 1 for w in widths[3::2]], dtype=np.int64)

    def describe(self) -> str:
        """Why the states do not pack (where ``fits`` is False)."""
        if self.bits > KEY_BITS:
            return f"a state needs {self.bits} bits, more than a key's {KEY_BITS}"
        if 5 * self.N + 4 > 255:
            return f"{self.N} sensors' actions do not fit a byte"
        return f"its rules' tables need {self.cells:,} cells, more than {MAX_CELLS:,}"

    # -- keys -------------------------------------------------------------------------------------

    def encode(self, state: tuple) -> int:
        p, k, ages, qs = state
        key = int(p) | (int(k) << self.k_shift)
        for i in range(self.N):
            key |= int(ages[i]) << int(self.a_shift[i])
            if self.voi:
                key |= self.distances[i].index(qs[i]) << int(self.q_shift[i])
        return key

    def decode(self, keys: np.ndarray) -> list[tuple]:
        """The state tuples of ``keys``, as voiopt.core.steps makes them (ints, distances as floats)."""
        keys = np.asarray(keys, dtype=np.int64)
        p = (keys & self.p_mask).tolist()
        k = ((keys >> self.k_shift) & self.k_mask).tolist()
        ages = [((keys >> int(self.a_shift[i])) & int(self.a_mask[i])).tolist() for i in range(self.N)]
        if self.voi:
            qs = [np.asarray(self.distances[i])[(keys >> int(self.q_shift[i])) & int(self.q_mask[i])].tolist()
                  for i in range(self.N)]
            qtuples = list(zip(*qs, strict=True)) if self.N else [()] * len(p)
        else:
            qtuples = [()] * len(p)
        return list(zip(p, k, zip(*ages, strict=True), qtuples, strict=True))

    # -- the rules as arrays -----------------------------------------------------------------------

    def tables(self, stop: Stop | None = None) -> dict[str, np.ndarray]:
        """The kernels' arrays: legal moves and uploads of every reachable (slot, point, moves
        used), each upload's success probability and key bits, and the reward table. ``stop``
        is looked at every slot (voiopt.runtime.stop.Stopped)."""
        steps, lat, N, T = self.steps, self.steps.lat, self.N, self.T
        n, K = lat.n_points, self.max_k + 1
        mv_n = np.zeros((T, n, K), dtype=np.int8)
        mv_m = np.zeros((T, n, K, 5), dtype=np.int8)
        mv_low = np.zeros((T, n, K, 5), dtype=np.int64)  # the next state's position fields
        up_n = np.zeros((T, n), dtype=np.int64)
        up_u = np.full((T, n, N + 1), -1, dtype=np.int64)
        up_ps = np.zeros((T, n, N + 1))
        dist0 = lat.from_start
        for t in range(T):
            halt_if_asked(stop)
            for p in np.flatnonzero(dist0 <= t):
                ups = steps.uploads(t, int(p))
                up_n[t, p] = len(ups)
                for j, (u, ps) in enumerate(ups):
                    up_u[t, p, j], up_ps[t, p, j] = u, ps
                for k in range(min(t, self.max_k) + 1):
                    moves = steps.moves(t, int(p), k)
                    mv_n[t, p, k] = len(moves)
                    for j, (m, q, k2) in enumerate(moves):
                        mv_m[t, p, k, j], mv_low[t, p, k, j] = m, q | (k2 << self.k_shift)
        win_clear = np.array([~((int(self.a_mask[i]) << int(self.a_shift[i])) | (int(self.q_mask[i]) << int(self.q_shift[i])))
                              for i in range(N)], dtype=np.int64)
        win_set = (np.int64(1) << self.a_shift)[:, None] + (self.qidx << self.q_shift[:, None])
        age_step = int(sum(1 << int(s) for s in self.a_shift))
        return {"mv_n": mv_n, "mv_m": mv_m, "mv_low": mv_low, "up_n": up_n, "up_u": up_u, "up_ps": up_ps,
                "win_clear": win_clear, "win_set": win_set.astype(np.int64), "voi": self.voi_table(),
                "fields": np.array([self.p_mask, self.k_shift, self.k_mask, self.low_bits, age_step], dtype=np.int64),
                "a_shift": self.a_shift, "a_mask": self.a_mask, "q_shift": self.q_shift, "q_mask": self.q_mask}

    def voi_table(self) -> np.ndarray:
        """V_i by Steps.voi at each reachable age (1..T, and the initial age + 0..T) and distance
        index; (N, 1, 1) zeros for the AoI objective, whose reward reads the ages alone."""
        if not self.voi:
            return np.zeros((self.N, 1, 1))
        T = self.T
        ages = [sorted(set(range(1, T + 1)) | set(range(a0, a0 + T + 1))) for a0 in self.initial_age]
        out = np.full((self.N, max(self.initial_age) + T + 1, max(map(len, self.distances))), np.nan)
        for i in range(self.N):
            for a in ages[i]:
                for j, q in enumerate(self.distances[i]):
                    out[i, a, j] = self.steps.voi(i, a, q)
        return out
