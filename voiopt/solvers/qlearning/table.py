"""The Q-table: an open-addressing hash table keyed by the packed state of models/mdp.py,
with the Q-values of each state's feasible actions in a separate pool.

Each slot of ``table`` (power-of-two size, linear probing, at most 70% full) holds the key
words, the row where the state's Q-values start in ``pool`` with the state's greedy action,
and max_a Q(s, a). A step reads the greedy action and the bootstrap value from the slot it
probes, so its critical path is one hash probe.
"""

from __future__ import annotations

import numpy as np

from voiopt.errors import OptionError
from voiopt.mdp import robot as mdp_mod
from voiopt.runtime.jit import njit
from voiopt.solvers.qlearning import prefault
from voiopt.solvers.qlearning.rng import mix

MAX_LOAD = 0.7  # hash slots at most 70% full

# ----------------------------------------------------------------------------- hash table

# A slot of ``table`` (uint64, one row per slot) is the W key words, then META = 1 + the row of
# the state's Q-values in ``pool`` shifted left by ARG_BITS, or'ed with the index of the
# state's first maximal Q-value (META 0 = empty slot), then the bits of that maximal Q-value
# (read and written through ``tablef``, a float64 view of the same memory). Keeping the
# greedy action and max_a Q(s, a) next to the key means a step's critical path is one hash
# probe; the Q row itself is read only to update one value, off that path.
ARG_BITS = np.uint64(16)
ARG_MASK = np.uint64((1 << 16) - 1)
MAX_ACTIONS = 1 << 16


@njit(cache=True, inline="always")
def room_for_episode(n_states, used, horizon, row, table, pool):
    """Whether one more episode fits without growing: at most horizon + 1 new states keep the
    table within MAX_LOAD, and their Q rows (at most ``row`` values each) fit the pool. The
    kernels stop at an episode boundary when it does not; QTable.grow then makes room."""
    return n_states + horizon + 1 <= MAX_LOAD * table.shape[0] and used + (horizon + 1) * row <= pool.shape[0]


@njit(cache=True, inline="always")
def encode_key(p, aoi, qidx, slot, moves, field_word, field_shift, key):
    key[:] = 0
    key[field_word[0]] |= np.uint64(p) << np.uint64(field_shift[0])
    N = aoi.shape[0]
    for i in range(N):
        f = 1 + 2 * i
        key[field_word[f]] |= np.uint64(aoi[i]) << np.uint64(field_shift[f])
        key[field_word[f + 1]] |= np.uint64(qidx[i]) << np.uint64(field_shift[f + 1])
    key[field_word[2 * N + 1]] |= np.uint64(slot) << np.uint64(field_shift[2 * N + 1])
    if field_word.shape[0] > 2 * N + 2:  # the moves made, with a binding budget
        key[field_word[2 * N + 2]] |= np.uint64(moves) << np.uint64(field_shift[2 * N + 2])


@njit(cache=True, inline="always")
def home_slot(k0, key, table):
    """The first slot find probes for the key (k0, key[1:])."""
    h = mix(k0)
    for w in range(1, key.shape[0]):
        h = mix(h ^ key[w])
    return np.int64(h & np.uint64(table.shape[0] - 1))


@njit(cache=True, inline="always")
def find(k0, key, table):
    """(slot, found): where the key is, or the empty slot where it would go. The key's first
    word is k0 (a scalar, so that the common one-word key stays in a register); key[0] is
    ignored and key[1:] are its other words."""
    mask = table.shape[0] - 1
    W = key.shape[0]
    s = home_slot(k0, key, table)
    while True:
        if table[s, W] == 0:
            return s, False
        if table[s, 0] == k0:
            same = True
            for w in range(1, W):
                if table[s, w] != key[w]:
                    same = False
                    break
            if same:
                return s, True
        s = (s + 1) & mask


@njit(cache=True, inline="always")
def row_start(table, s):
    """Where the Q-values of the state in slot s start in the pool."""
    return np.int64(table[s, table.shape[1] - 2] >> ARG_BITS) - 1


@njit(cache=True, inline="always")
def greedy_action(table, s):
    """The first action of maximal Q-value in slot s."""
    return np.int64(table[s, table.shape[1] - 2] & ARG_MASK)


@njit(cache=True, inline="always")
def insert(table, tablef, s, k0, key, pool, used, n, q_init):
    """Store the key (k0, key[1:]) in empty slot s with n fresh Q-values at pool[used:];
    returns the pool's new fill, used + n."""
    W = key.shape[0]
    table[s, 0] = k0
    for w in range(1, W):
        table[s, w] = key[w]
    table[s, W] = np.uint64(used + 1) << ARG_BITS  # greedy action 0
    tablef[s, W + 1] = q_init
    for j in range(n):
        pool[used + j] = q_init
    return used + n


@njit(cache=True, inline="always")
def hand_back(rng, state, counts, n_states, used):
    """A chunk's end: the stream's state and the table's fill, back to Python's arrays."""
    rng[0] = state
    counts[0], counts[1] = n_states, used


@njit(cache=True, nogil=True)
def _rehash(old, table):
    """Insert every entry of old into the empty, larger table (whole slots, word by word)."""
    W = table.shape[1] - 2
    mask = table.shape[0] - 1
    for o in range(old.shape[0]):
        if old[o, W] == 0:
            continue
        h = np.uint64(0)
        for w in range(W):
            h = mix(h ^ old[o, w])
        s = np.int64(h & np.uint64(mask))
        while table[s, W] != 0:
            s = (s + 1) & mask
        for c in range(W + 2):
            table[s, c] = old[o, c]


class QTable:
    """The growable hash table and Q-value pool of one training run."""

    def __init__(self, model: mdp_mod.MDP, q_init: float, max_bytes: float | None, slots: int = 1 << 15):
        self.model = model
        self.q_init = float(q_init)
        self.max_bytes = float("inf") if max_bytes is None else float(max_bytes)
        if model.max_actions > MAX_ACTIONS:
            raise OptionError(f"at most {MAX_ACTIONS} actions per state, got {model.max_actions}")
        self.counts = np.zeros(2, np.int64)  # [states, Q-values used]
        self.table = np.zeros((_pow2(slots), model.n_words + 2), np.uint64)
        mean_actions = float(model.n_actions.mean())
        pool_len = int(MAX_LOAD * len(self.table) * mean_actions) + self._margin()
        # The pool grows inside one reservation of address space as large as the memory limit:
        # pages are backed only when first written, so growing the pool is a longer view of the
        # reservation, not a copy. (Q-values are written when their state is stored, so the
        # pool needs no zeroing.)
        try:
            reserve = int(self.max_bytes // 8) if self.max_bytes < float("inf") else 0
            self._reserved = np.empty(max(pool_len, reserve), np.float64)
        except MemoryError:  # no address space to spare: grow by copying
            self._reserved = np.empty(pool_len, np.float64)
        self.pool = self._reserved[:pool_len]
        self._next = None  # the next, doubled table, allocated and backed ahead of time (_prepare)
        self._next_job = None
        self._backed = 0  # how much of the pool has been backed ahead of time
        self._prepare()

    def _prepare(self) -> None:
        """Have the pages the kernel writes next backed on another core (voiopt/prefault.py):
        the pool a quarter of its use (at least 32 MB) ahead of it, and once the table is 65%
        full (of at most 70%), the doubled table that grow() will rehash into, if it fits the
        memory limit beside the table and the pool. Not earlier: a run that ends before that
        growth would have allocated and backed it in vain (drop_next lets it go)."""
        ahead = min(len(self.pool), int(self.counts[1]) + max(int(self.counts[1]) // 4, 4 << 20))
        if ahead > self._backed and prefault.populate(self._reserved, self._backed, ahead):
            self._backed = ahead
        if self._next is None and self.counts[0] > 0.65 * len(self.table) \
                and self.nbytes + 2 * self.table.nbytes <= self.max_bytes:
            try:
                self._next = np.zeros((2 * len(self.table), self.table.shape[1]), np.uint64)
            except MemoryError:  # only ever a head start: growth allocates it when it must
                return
            self._next_job = prefault.populate(self._next)

    def drop_next(self) -> None:
        """Let go of the table allocated ahead of a growth (at the end of training, or when it
        does not fit beside a growth of the pool)."""
        if self._next_job is not None:
            self._next_job.cancel()
        self._next, self._next_job = None, None

    def _margin(self) -> int:
        return (self.model.horizon + 1) * self.model.max_actions

    @property
    def n_states(self) -> int:
        return int(self.counts[0])

    @property
    def nbytes(self) -> int:
        return self.table.nbytes + self.pool.nbytes

    def grow(self) -> bool:
        """Double whatever is short for one more episode; False if that passes the memory limit."""
        m = self.model
        slots = len(self.table)
        if self.counts[0] + m.horizon + 1 > MAX_LOAD * slots:
            slots *= 2
        pool_len = len(self.pool)
        while self.counts[1] + self._margin() > pool_len:
            pool_len *= 2
        new_bytes = (slots * self.table.shape[1] if slots != len(self.table) else 0) * 8
        new_bytes += (pool_len if pool_len != len(self.pool) else 0) * 8
        if self._next is not None and slots == len(self.table) and \
                self.nbytes + new_bytes + self._next.nbytes > self.max_bytes:
            self.drop_next()  # the table allocated ahead does not fit beside this growth of the pool
        if self.nbytes + new_bytes > self.max_bytes:  # old and new arrays live together briefly
            return False
        if slots != len(self.table):
            table, self._next, self._next_job = self._next, None, None  # before the rehash: an interrupt
            if table is None or len(table) != slots:  # in it must not leave a filled table to reuse
                table = np.zeros((slots, self.table.shape[1]), np.uint64)
            _rehash(self.table, table)
            self.table = table
        if pool_len > len(self._reserved):
            reserved = np.empty(pool_len, np.float64)
            reserved[: len(self.pool)] = self.pool
            self._reserved = reserved
        self.pool = self._reserved[:pool_len]
        self._prepare()
        return True

    def run(self, n_episodes: int, chunk) -> tuple[int, bool]:
        """Run n_episodes through ``chunk(n)`` (a kernel that runs up to n episodes and stops at
        an episode boundary when the table might overflow), growing the table between calls.
        Returns (episodes run, False if stopped by the memory limit)."""
        done = 0
        while done < n_episodes:
            done += chunk(n_episodes - done)
            self._prepare()
            if done < n_episodes and not self.grow():
                return done, False
        return done, True

    def to_dict(self, row_length=None) -> dict[tuple, list[float]]:
        """{state: Q-values of its feasible actions}, for tests and inspection. ``row_length(state)``
        is how many there are (default: the actions at the state's point)."""
        m = self.model
        W = m.n_words
        length = row_length or (lambda state: int(m.n_actions[state[0]]))
        out = {}
        for slot in self.table[self.table[:, W] != 0]:
            state = m.decode(slot[:W])
            r = (int(slot[W]) >> int(ARG_BITS)) - 1
            out[state] = self.pool[r: r + length(state)].tolist()
        return out


def _pow2(x: int) -> int:
    return 1 << max(4, (int(x) - 1).bit_length())
