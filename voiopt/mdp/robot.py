"""The MDP of MODEL.md section 7 as flat arrays, shared by Q-learning and the Gymnasium env.

State s_t = (p(t), A(t), q(t)). Effective distances come from a finite set, so q_i is kept as
an index: 0 is sensor i's initial distance q_i(0), 1 + p is its distance from lattice point p.
Ages are at most A_i(0) + T. States are tuples (p, A, q, slot, moves) where slot is always 0 in
the paper's MDP; with ``slot_in_state`` it is t, which makes the finite horizon exact (an option
beyond the paper). moves, the moves made so far, is 0 unless a ``max_moves`` budget binds
(MODEL.md section 9); then it is part of the state, and with an ``end`` or such a budget the
actions that would leave no way to end in the slots and moves left are masked (``feasible``). A state packs exactly into a few 64-bit words (no field straddles a word),
which is the key of the compiled Q-table.

Actions available at point p are numbered 0 .. n_actions[p]-1, uploads outer (none first, then
the in-range sensors ascending) and moves inner (stay, N, S, E, W, skipping those that leave
the area). Reward r_{t+1} = min_i V_i(t+1) - penalty*[no upload] (VoI), with V in bit/s as the
paper writes it (``reward_units="bit/s"``, the default) or V/B (``"bit/s/Hz"``, kept for
comparison), or -max_i A_i(t+1) - penalty*[no upload] (AoI variant). MODEL.md section 7.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from voiopt.core import physics
from voiopt.core.instance import Instance
from voiopt.core.simulate import advance
from voiopt.errors import OptionError
from voiopt.grid import lattice as lattice_mod
from voiopt.objectives import Worth

REWARDS = ("voi", "aoi")
REWARD_UNITS = ("bit/s", "bit/s/Hz")
IDLE_PENALTY = 100.0


def check_reward_units(units: str) -> str:
    if units not in REWARD_UNITS:
        raise OptionError(f"reward_units: must be one of {', '.join(REWARD_UNITS)}, got {units!r}")
    return units


@dataclass(frozen=True, eq=False)
class MDP:
    instance: Instance
    reward: str  # "voi" or "aoi"
    penalty: float
    reward_units: str  # "bit/s" (the paper as written) or "bit/s/Hz" (V / B)
    slot_in_state: bool  # beyond the paper: the slot t is part of the state
    start: int  # lattice index of p(0)
    initial_aoi: np.ndarray  # (N,) A_i(0)
    n_actions: np.ndarray  # (n,) feasible actions at each point
    action_upload: np.ndarray  # (n, K) sensor uploaded by action k at p, -1 = none (pad -1)
    action_move: np.ndarray  # (n, K) move index 0..4 (stay, N, S, E, W)
    action_next: np.ndarray  # (n, K) p(t+1)
    voi_reward: np.ndarray  # (N, max_age + 1, n + 1) V_i in reward units for age a and distance index
    field_word: np.ndarray  # (2 + 2N [+ 1],) word of each packed field: p, A_i and q_i per sensor, slot, moves
    field_shift: np.ndarray  # bit offset of each field in its word
    field_width: np.ndarray  # bits of each field
    n_words: int
    to_end: np.ndarray  # (n,) fewest moves to end (0 everywhere without one), MODEL.md section 9
    budget: int  # the moves a plan may make, min(max_moves, T - 1)
    masked: bool  # an end or a binding budget: some actions are infeasible in some slots
    moves_in_state: bool  # a binding budget: the moves made so far are part of the state

    @property
    def n_sensors(self) -> int:
        return self.instance.n_sensors

    @property
    def horizon(self) -> int:
        return self.instance.horizon

    @property
    def max_actions(self) -> int:
        return self.action_upload.shape[1]

    def initial_state(self) -> tuple[int, tuple[int, ...], tuple[int, ...], int, int]:
        """s_0 = (start, A(0), q(0), 0, 0) with every q_i at index 0 (its initial distance); the
        last two are the slot and the moves made, each 0 unless it is part of the state."""
        return self.start, tuple(int(a) for a in self.initial_aoi), (0,) * self.n_sensors, 0, 0

    def feasible(self, state, t: int) -> np.ndarray:
        """Bool mask over the action numbers at the state's point in slot t: the move leaves a
        way to ``end`` within the slots and moves left (MODEL.md section 9). The slot t is
        needed because the paper's state does not hold it; every action is feasible in the
        last slot, and without an end or a binding budget in every slot."""
        p, moves = state[0], self.moves_made(state, t)
        k = int(self.n_actions[p])
        if not self.masked or t + 1 >= self.horizon:
            return np.ones(k, dtype=bool)
        nxt = self.action_next[p, :k]
        return lattice_mod.build(self.instance).can_finish(nxt, t + 1, moves + (nxt != p))

    def moves_made(self, state, t: int) -> int:
        """The moves made so far: in the state with a binding budget; otherwise they do not
        matter (no budget binds, so only slots limit the way to end)."""
        return int(state[4]) if self.moves_in_state else 0

    def actions(self, p: int) -> list[tuple[int, int]]:
        """The feasible actions at p as (upload or -1, move index), in action-number order."""
        k = int(self.n_actions[p])
        return list(zip(self.action_upload[p, :k].tolist(), self.action_move[p, :k].tolist(), strict=True))

    def action_number(self, p: int, upload: int, move: int) -> int:
        """The number of action (upload, move) at p; raises if it is not feasible there."""
        for k, (u, m) in enumerate(self.actions(p)):
            if u == upload and m == move:
                return k
        raise ValueError(f"action (upload {upload}, move {move}) is not feasible at point {p}")

    def step(self, state, k: int):
        """(next state, reward) after action number k; plain Python, for the env and tests."""
        p, aoi, qidx, slot, moves = state
        u = int(self.action_upload[p, k])
        aoi, qidx = (tuple(a.tolist()) for a in advance(np.array(aoi, np.int64), np.array(qidx, np.int64), u, 1 + p))
        slot = slot + 1 if self.slot_in_state else 0
        nxt = int(self.action_next[p, k])
        moves = moves + (nxt != p) if self.moves_in_state else 0
        return (nxt, aoi, qidx, slot, moves), self.reward_of(aoi, qidx, u)

    def reward_of(self, aoi, qidx, upload: int) -> float:
        """r_{t+1} of MODEL.md section 7 for the next state's ages and distance indices."""
        idle = self.penalty if upload < 0 else 0.0
        if self.reward == Worth.AOI:
            return -float(max(aoi)) - idle
        return min(float(self.voi_reward[i, a, q]) for i, (a, q) in enumerate(zip(aoi, qidx, strict=True))) - idle

    def encode(self, state) -> np.ndarray:
        """The packed key of a state: n_words uint64 words."""
        p, aoi, qidx, slot, moves = state
        words = [0] * self.n_words
        values = [p]
        for a, q in zip(aoi, qidx, strict=True):
            values += [a, q]
        values.append(slot)
        if self.moves_in_state:
            values.append(moves)
        for f, v in enumerate(values):
            words[self.field_word[f]] |= int(v) << int(self.field_shift[f])
        return np.array(words, dtype=np.uint64)

    def decode(self, words) -> tuple[int, tuple[int, ...], tuple[int, ...], int, int]:
        """The state of a packed key (inverse of ``encode``)."""
        values = [
            (int(words[w]) >> int(s)) & ((1 << int(b)) - 1)
            for w, s, b in zip(self.field_word, self.field_shift, self.field_width, strict=True)
        ]
        N = self.n_sensors
        moves = values[2 * N + 2] if self.moves_in_state else 0
        return values[0], tuple(values[1:2 * N + 1:2]), tuple(values[2:2 * N + 1:2]), values[2 * N + 1], moves


def bits_for(max_value: int) -> int:
    return max(1, int(max_value).bit_length())


def pack(widths: list[int]) -> tuple[np.ndarray, np.ndarray, int]:
    """(word, bit offset) of each field of these widths packed into 64-bit words, no field
    straddling a word, and the number of words."""
    field_word, field_shift, word, used = [], [], 0, 0
    for w in widths:
        if used + w > 64:
            word, used = word + 1, 0
        field_word.append(word)
        field_shift.append(used)
        used += w
    return np.array(field_word, dtype=np.int64), np.array(field_shift, dtype=np.int64), word + 1


MAX_RETURN = 1e300  # an episode's penalties stay below it: a return of -inf would end learning silently


def check_penalty(penalty, horizon: int | None = None) -> None:
    """The idle penalty: a finite number >= 0 (it is subtracted when nothing is uploaded), and
    at most MAX_RETURN / T, so that an episode's return stays finite."""
    if isinstance(penalty, bool) or not isinstance(penalty, (int, float, np.integer, np.floating)) or not math.isfinite(penalty):
        raise OptionError(f"penalty: must be a finite number >= 0, got {penalty!r}")
    if penalty < 0:
        raise OptionError(f"penalty: must be >= 0 (it is subtracted in each slot without an upload), got {penalty!r}")
    if horizon is not None and penalty * horizon > MAX_RETURN:
        raise OptionError(f"penalty: must be at most {MAX_RETURN:g} / horizon ({horizon}) = {MAX_RETURN / horizon:.3g}, "
                          f"so that an episode's return stays finite, got {penalty!r}")


def build(instance: Instance, reward: str = "voi", penalty: float = IDLE_PENALTY,
          slot_in_state: bool = False, reward_units: str = "bit/s", stop=None) -> MDP:
    """The arrays of the MDP of ``instance`` with the VoI or AoI reward; voiopt.runtime.stop.Stopped if
    ``stop`` says stop while its table of VoI is computed."""
    if reward not in REWARDS:
        raise OptionError(f"reward: must be 'voi' or 'aoi', got {reward!r}")
    check_reward_units(reward_units)
    check_penalty(penalty, instance.horizon)
    lat = lattice_mod.build(instance)
    n, N, T = lat.n_points, instance.n_sensors, instance.horizon
    initial_aoi = np.array([s.initial_aoi for s in instance.sensors], dtype=np.int64)
    max_age = int(initial_aoi.max()) + T

    per_point = []
    for p in range(n):
        uploads = [-1, *np.flatnonzero(lat.in_range[:, p]).tolist()]
        moves = [m for m in range(5) if lat.neighbors[p, m] >= 0]
        per_point.append([(u, m, int(lat.neighbors[p, m])) for u in uploads for m in moves])
    K = max(len(a) for a in per_point)
    n_actions = np.array([len(a) for a in per_point], dtype=np.int64)
    action_upload = np.full((n, K), -1, dtype=np.int64)
    action_move = np.full((n, K), -1, dtype=np.int64)
    action_next = np.full((n, K), -1, dtype=np.int64)
    for p, acts in enumerate(per_point):
        for k, (u, m, nxt) in enumerate(acts):
            action_upload[p, k], action_move[p, k], action_next[p, k] = u, m, nxt

    # V_i (bit/s, or / B) for every age 0..max_age and distance index (0 = initial, 1 + p = from point p)
    dist = np.concatenate(
        [np.array([[instance.initial_distance(i)] for i in range(N)]), lat.distance], axis=1
    )
    voi = _voi_table(instance, max_age, dist, stop)
    if reward_units == "bit/s/Hz":
        voi = voi / instance.channel.bandwidth_hz
    voi_reward = np.ascontiguousarray(voi)

    moves_in_state = lat.budget < T - 1
    # moves made reach budget + 1 after a move in the last slot (every action is feasible there)
    widths = [bits_for(n - 1)] + [bits_for(max_age), bits_for(n)] * N + [bits_for(T)] + ([bits_for(lat.budget + 1)] if moves_in_state else [])
    field_word, field_shift, n_words = pack(widths)
    arrays = [initial_aoi, n_actions, action_upload, action_move, action_next, voi_reward]
    for a in arrays:
        a.setflags(write=False)
    return MDP(
        instance, reward, float(penalty), reward_units, bool(slot_in_state), int(lat.start), initial_aoi, n_actions, action_upload,
        action_move, action_next, voi_reward, field_word, field_shift, np.array(widths, dtype=np.int64), n_words,
        # to_end as a writable copy, with an end or without: one numba type, so one compile
        np.array(lat.to_end, dtype=np.int64), int(lat.budget), bool(lat.end >= 0 or moves_in_state),
        moves_in_state,
    )


VOI_BLOCK = 1 << 20  # entries of the VoI table computed between two checks of the stop rule (about 0.3 s)


def _voi_table(instance: Instance, max_age: int, dist: np.ndarray, stop=None) -> np.ndarray:
    """V_i for every sensor i, age 0..max_age and distance index: (N, max_age + 1, 1 + n). A few
    hundred nanoseconds an entry (libm, for the same bits everywhere), so at T = 3 x 10^5 it
    took 20 s: computed a block of ages at a time, ``stop`` checked between blocks."""
    rho = np.array([s.rho for s in instance.sensors])[:, None, None]
    power = np.array([s.power_w for s in instance.sensors])[:, None, None]
    ages = np.arange(max_age + 1, dtype=float)[None, :, None]
    return physics.voi_blocks(ages, dist[:, None, :], rho, power, instance.channel, axis=1, block=VOI_BLOCK, stop=stop)
