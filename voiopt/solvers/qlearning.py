"""The paper's Algorithm 1 (tabular Q-learning), compiled with numba, and its greedy rollout.

The Q-table is an open-addressing hash table keyed by the packed state of models/mdp.py:
each slot of ``table`` (power-of-two size, linear probing, at most 70% full) holds the key
words, the row where the state's Q-values (one per feasible action of its position) start in
``pool`` with the state's greedy action, and max_a Q(s, a). A step reads the greedy action and
the bootstrap value from the slot it probes, so its critical path is one hash probe; the Q
row is touched only to update one value. The key is updated in place each step, not rebuilt.
Training runs in chunks of whole episodes; between chunks Python grows the arrays when
needed (up to ``max_memory_mb``), updates the progress bar and checks the stop flag. Random
numbers come from splitmix64, so a plain-Python Algorithm 1 can reproduce the run bit for bit
(benchmarks/reference_qlearning.py).
"""

from __future__ import annotations

import math
import time

import numba as nb
import numpy as np
from rich.progress import TextColumn

from voiopt.errors import OptionError
from voiopt.instance import Instance
from voiopt.interrupt import progress_bar, stop_on_interrupt
from voiopt.models import mdp as mdp_mod
from voiopt.result import Plan, Result
from voiopt.simulate import check_objective, simulate_indices

BETA, GAMMA, EPISODES = 0.75, 0.9, 1_000_000
MAX_LOAD = 0.7  # hash slots at most 70% full
_M64 = (1 << 64) - 1

# ----------------------------------------------------------------------------- random numbers

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_TWO_M53 = 1.0 / 9007199254740992.0


@nb.njit(cache=True, inline="always")
def _mix(z):
    z = (z ^ (z >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    return z ^ (z >> _S31)


@nb.njit(cache=True, inline="always")
def _uniform(rng):
    """Next double in [0, 1) from the splitmix64 state rng[0]."""
    rng[0] += _GOLDEN
    return float(_mix(rng[0]) >> _S11) * _TWO_M53


def seed_state(seed: int) -> int:
    """The splitmix64 state for a user seed (the seed itself, as an unsigned 64-bit word)."""
    return int(seed) & _M64


# ----------------------------------------------------------------------------- hash table

# A slot of ``table`` (uint64, one row per slot) is the W key words, then META = 1 + the row of
# the state's Q-values in ``pool`` shifted left by _ARG_BITS, or'ed with the index of the
# state's first maximal Q-value (META 0 = empty slot), then the bits of that maximal Q-value
# (read and written through ``tablef``, a float64 view of the same memory). Keeping the
# greedy action and max_a Q(s, a) next to the key means a step's critical path is one hash
# probe; the Q row itself is read only to update one value, off that path.
_ARG_BITS = np.uint64(16)
_ARG_MASK = np.uint64((1 << 16) - 1)
MAX_ACTIONS = 1 << 16


@nb.njit(cache=True, inline="always")
def _encode(p, aoi, qidx, slot, field_word, field_shift, key):
    key[:] = 0
    key[field_word[0]] |= np.uint64(p) << np.uint64(field_shift[0])
    N = aoi.shape[0]
    for i in range(N):
        f = 1 + 2 * i
        key[field_word[f]] |= np.uint64(aoi[i]) << np.uint64(field_shift[f])
        key[field_word[f + 1]] |= np.uint64(qidx[i]) << np.uint64(field_shift[f + 1])
    key[field_word[2 * N + 1]] |= np.uint64(slot) << np.uint64(field_shift[2 * N + 1])


@nb.njit(cache=True, inline="always")
def _hash(key):
    h = np.uint64(0)
    for w in range(key.shape[0]):
        h = _mix(h ^ key[w])
    return h


@nb.njit(cache=True, inline="always")
def _find(k0, key, table):
    """(slot, found): where the key is, or the empty slot where it would go. The key's first
    word is k0 (a scalar, so that the common one-word key stays in a register); key[0] is
    ignored and key[1:] are its other words."""
    mask = table.shape[0] - 1
    W = key.shape[0]
    h = _mix(k0)  # = _hash(key)
    for w in range(1, W):
        h = _mix(h ^ key[w])
    s = np.int64(h & np.uint64(mask))
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


@nb.njit(cache=True, inline="always")
def _row(table, s):
    """The start of slot s's Q-values in the pool."""
    return np.int64(table[s, table.shape[1] - 2] >> _ARG_BITS) - 1


@nb.njit(cache=True, inline="always")
def _greedy(table, s):
    """The first action of maximal Q-value in slot s."""
    return np.int64(table[s, table.shape[1] - 2] & _ARG_MASK)


@nb.njit(cache=True, inline="always")
def _insert(table, tablef, s, k0, key, pool, used, n, q_init):
    """Store the key (k0, key[1:]) in empty slot s with n fresh Q-values at pool[used:]."""
    W = key.shape[0]
    table[s, 0] = k0
    for w in range(1, W):
        table[s, w] = key[w]
    table[s, W] = np.uint64(used + 1) << _ARG_BITS  # greedy action 0
    tablef[s, W + 1] = q_init
    for j in range(n):
        pool[used + j] = q_init


@nb.njit(cache=True)
def _rehash(old, table):
    """Insert every entry of old into the empty, larger table (whole slots, word by word)."""
    W = table.shape[1] - 2
    mask = table.shape[0] - 1
    for o in range(old.shape[0]):
        if old[o, W] == 0:
            continue
        h = np.uint64(0)
        for w in range(W):
            h = _mix(h ^ old[o, w])
        s = np.int64(h & np.uint64(mask))
        while table[s, W] != 0:
            s = (s + 1) & mask
        for c in range(W + 2):
            table[s, c] = old[o, c]


# ----------------------------------------------------------------------------- Algorithm 1


@nb.njit(cache=True)
def _train(
    n_episodes, horizon, eps, eps0, beta, gamma, q_init, penalty, aoi_reward, slot_in_state,
    start, initial_aoi, n_actions, action_upload, action_next, voi_reward,
    field_word, field_shift, field_width, table, tablef, pool, counts, rng,
):
    """Run up to n_episodes episodes; stop early (at an episode boundary) when the table could
    overflow during the next one. counts = [entries, pool used]; eps[0] and rng[0] are updated
    in place. Returns the number of episodes run."""
    N = initial_aoi.shape[0]
    K = action_upload.shape[1]
    W = table.shape[1] - 2
    META, QMAX = W, W + 1
    max_states = MAX_LOAD * table.shape[0]
    aoi = np.empty(N, np.int64)
    qidx = np.empty(N, np.int64)
    # the packed key is updated in place each step: every age field +1 (and the slot field,
    # if in the state), then the new position and, on an upload, that sensor's two fields
    key0 = np.empty(W, np.uint64)
    _encode(start, initial_aoi, np.zeros(N, np.int64), 0, field_word, field_shift, key0)
    key = np.empty(W, np.uint64)
    inc = np.zeros(W, np.uint64)
    for i in range(N):
        inc[field_word[1 + 2 * i]] += np.uint64(1) << np.uint64(field_shift[1 + 2 * i])
    if slot_in_state:
        inc[field_word[2 * N + 1]] += np.uint64(1) << np.uint64(field_shift[2 * N + 1])
    clear = np.empty(2 + 2 * N, np.uint64)  # ~(field mask) per field
    for f in range(2 + 2 * N):
        clear[f] = ~(((np.uint64(1) << np.uint64(field_width[f])) - np.uint64(1)) << np.uint64(field_shift[f]))
    ps, pclear = np.uint64(field_shift[0]), clear[0]  # the position is in word 0
    inc0 = inc[0]

    bg = beta * gamma
    state = rng[0]
    n_states, used = counts[0], counts[1]
    for ep in range(n_episodes):
        if n_states + horizon + 1 > max_states or used + (horizon + 1) * K > pool.shape[0]:
            rng[0] = state
            counts[0], counts[1] = n_states, used
            return ep
        p = start
        for i in range(N):
            aoi[i] = initial_aoi[i]
            qidx[i] = 0
        k0 = key0[0]
        for w in range(1, W):
            key[w] = key0[w]
        cur, found = _find(k0, key, table)
        if not found:
            _insert(table, tablef, cur, k0, key, pool, used, n_actions[p], q_init)
            n_states += 1
            used += n_actions[p]
        epsilon = eps[0]
        for t in range(horizon):
            # epsilon-greedy: x, and if exploring a second number for the action
            state += _GOLDEN
            x = float(_mix(state) >> _S11) * _TWO_M53
            if x < epsilon:
                state += _GOLDEN
                k = int(float(_mix(state) >> _S11) * _TWO_M53 * n_actions[p])
            else:
                k = _greedy(table, cur)
            u = action_upload[p, k]
            p_next = action_next[p, k]
            for i in range(N):
                aoi[i] += 1
            k0 += inc0
            for w in range(1, W):
                key[w] += inc[w]
            k0 = (k0 & pclear) | (np.uint64(p_next) << ps)
            if u >= 0:
                aoi[u] = 1
                qidx[u] = 1 + p
                fa, fq = 1 + 2 * u, 2 + 2 * u
                va = np.uint64(1) << np.uint64(field_shift[fa])
                vq = np.uint64(1 + p) << np.uint64(field_shift[fq])
                wa, wq = field_word[fa], field_word[fq]
                if wa == 0:
                    k0 = (k0 & clear[fa]) | va
                else:
                    key[wa] = (key[wa] & clear[fa]) | va
                if wq == 0:
                    k0 = (k0 & clear[fq]) | vq
                else:
                    key[wq] = (key[wq] & clear[fq]) | vq
            if aoi_reward:
                worst = aoi[0]
                for i in range(1, N):
                    if aoi[i] > worst:
                        worst = aoi[i]
                r = -float(worst)
            else:
                r = voi_reward[0, aoi[0], qidx[0]]
                for i in range(1, N):
                    v = voi_reward[i, aoi[i], qidx[i]]
                    if v < r:
                        r = v
            if u < 0:
                r = r - penalty
            # find s_{t+1}; store it unless it is s_T (never acted in)
            nxt, found = _find(k0, key, table)
            if found:
                future = tablef[nxt, QMAX]
            else:
                future = q_init
                if t + 1 < horizon:
                    _insert(table, tablef, nxt, k0, key, pool, used, n_actions[p_next], q_init)
                    n_states += 1
                    used += n_actions[p_next]
            # Q(s_t, k) and the cached first maximum of s_t
            meta = table[cur, META]
            row = np.int64(meta >> _ARG_BITS) - 1
            v = (1.0 - beta) * pool[row + k] + beta * r + bg * future
            pool[row + k] = v
            a = np.int64(meta & _ARG_MASK)
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
                    table[cur, META] = (meta & ~_ARG_MASK) | np.uint64(a)
                    tablef[cur, QMAX] = best
            elif v > best or (v == best and k < a):
                table[cur, META] = (meta & ~_ARG_MASK) | np.uint64(k)
                tablef[cur, QMAX] = v
            p = p_next
            cur = nxt
        eps[0] = eps[0] - eps0
    rng[0] = state
    counts[0], counts[1] = n_states, used
    return n_episodes


@nb.njit(cache=True)
def _rollout(horizon, slot_in_state, start, initial_aoi, n_actions, action_upload, action_next,
             field_word, field_shift, table):
    """The greedy plan of the table: first maximal action in each state (action 0 if unseen)."""
    N = initial_aoi.shape[0]
    aoi = initial_aoi.copy()
    qidx = np.zeros(N, np.int64)
    key = np.empty(table.shape[1] - 2, np.uint64)
    idx = np.empty(horizon, np.int64)
    sched = np.empty(horizon, np.int64)
    p = start
    for t in range(horizon):
        _encode(p, aoi, qidx, t * slot_in_state, field_word, field_shift, key)
        s, found = _find(key[0], key, table)
        k = _greedy(table, s) if found else 0
        u = action_upload[p, k]
        idx[t] = p
        sched[t] = u
        for i in range(N):
            aoi[i] += 1
        if u >= 0:
            aoi[u] = 1
            qidx[u] = 1 + p
        p = action_next[p, k]
    return idx, sched


# ----------------------------------------------------------------------------- the table


class QTable:
    """The growable hash table and Q-value pool of one training run."""

    def __init__(self, model: mdp_mod.MDP, q_init: float, max_memory_mb: float, slots: int = 1 << 15):
        self.model = model
        self.q_init = float(q_init)
        self.max_bytes = max_memory_mb * 2**20
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
            self._reserved = np.empty(max(pool_len, int(self.max_bytes // 8)), np.float64)
        except MemoryError:  # no address space to spare: grow by copying
            self._reserved = np.empty(pool_len, np.float64)
        self.pool = self._reserved[:pool_len]

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
        if self.nbytes + new_bytes > self.max_bytes:  # old and new arrays live together briefly
            return False
        if slots != len(self.table):
            table = np.zeros((slots, self.table.shape[1]), np.uint64)
            _rehash(self.table, table)
            self.table = table
        if pool_len > len(self._reserved):
            reserved = np.empty(pool_len, np.float64)
            reserved[: len(self.pool)] = self.pool
            self._reserved = reserved
        self.pool = self._reserved[:pool_len]
        return True

    def to_dict(self) -> dict[tuple, list[float]]:
        """{state: Q-values of its feasible actions}, for tests and inspection."""
        m = self.model
        W = m.n_words
        out = {}
        for slot in self.table[self.table[:, W] != 0]:
            state = m.decode(slot[:W])
            r = (int(slot[W]) >> int(_ARG_BITS)) - 1
            out[state] = self.pool[r: r + int(m.n_actions[state[0]])].tolist()
        return out


def _pow2(x: int) -> int:
    return 1 << max(4, (int(x) - 1).bit_length())


def train(model: mdp_mod.MDP, table: QTable, n_episodes: int, eps: np.ndarray, eps0: float,
          beta: float, gamma: float, rng: np.ndarray) -> tuple[int, bool]:
    """Run n_episodes of Algorithm 1, growing the table as needed.
    Returns (episodes run, False if stopped by the memory limit)."""
    done = 0
    while done < n_episodes:
        done += _train(
            n_episodes - done, model.horizon, eps, eps0, beta, gamma, table.q_init, model.penalty,
            model.reward == "aoi", int(model.slot_in_state), model.start, model.initial_aoi, model.n_actions,
            model.action_upload, model.action_next, model.voi_reward, model.field_word,
            model.field_shift, model.field_width, table.table, table.table.view(np.float64), table.pool,
            table.counts, rng,
        )
        if done < n_episodes and not table.grow():
            return done, False
    return done, True


def rollout(model: mdp_mod.MDP, table: QTable) -> tuple[np.ndarray, np.ndarray]:
    """(point indices, schedule with -1) of the greedy plan of the table."""
    return _rollout(
        model.horizon, int(model.slot_in_state), model.start, model.initial_aoi, model.n_actions, model.action_upload,
        model.action_next, model.field_word, model.field_shift, table.table,
    )


# ----------------------------------------------------------------------------- the solvers

_WARM = False


def warm_up() -> float:
    """Compile (or load from numba's cache) the kernels once per process, on a tiny MDP, so
    that a solve's runtime_s measures Algorithm 1 alone; returns the seconds this took (0 when
    already done). The kernels' argument types do not depend on the instance."""
    global _WARM
    if _WARM:
        return 0.0
    from voiopt.generate import generate

    t0 = time.perf_counter()
    model = mdp_mod.build(generate(1, 2, width=1.0, height=1.0, seed=0, name="warm-up"))
    table = QTable(model, 0.0, 64)
    train(model, table, 1, np.array([1.0]), 1.0, BETA, GAMMA, np.array([1], dtype=np.uint64))
    rollout(model, table)
    _WARM = True
    return time.perf_counter() - t0



def _check_options(episodes, seed, beta, gamma, q_init, penalty, time_limit, max_memory_mb):
    def bad(name, value, rule):
        raise OptionError(f"{name}: {rule}, got {value!r}")

    if isinstance(episodes, bool) or not isinstance(episodes, (int, np.integer)) or episodes < 1:
        bad("episodes", episodes, "must be an integer >= 1")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        bad("seed", seed, "must be an integer >= 0")
    for name, v in (("beta", beta), ("gamma", gamma)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v <= 1:
            bad(name, v, "must be in (0, 1]")
    for name, v in (("q_init", q_init), ("penalty", penalty)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            bad(name, v, "must be a finite number")
    if time_limit is not None and (isinstance(time_limit, bool) or not isinstance(time_limit, (int, float))
                                   or not time_limit > 0):
        bad("time_limit", time_limit, "must be a number of seconds > 0")
    if isinstance(max_memory_mb, bool) or not isinstance(max_memory_mb, (int, float)) or not max_memory_mb >= 1:
        bad("max_memory_mb", max_memory_mb, "must be a number of MiB >= 1")


def _run(instance: Instance, objective: str, reward: str, method: str, *, progress: bool,
         episodes: int, seed: int, beta: float, gamma: float, q_init: float, penalty: float,
         time_limit: float | None, max_memory_mb: float, slot_in_state: bool, reward_units: str) -> Result:
    check_objective(objective)
    _check_options(episodes, seed, beta, gamma, q_init, penalty, time_limit, max_memory_mb)
    mdp_mod.check_reward_units(reward_units)
    if not isinstance(slot_in_state, bool):
        raise OptionError(f"slot_in_state: must be true or false, got {slot_in_state!r}")
    startup_s = warm_up()
    t0 = time.perf_counter()
    model = mdp_mod.build(instance, reward, penalty, slot_in_state, reward_units)
    table = QTable(model, q_init, max_memory_mb)
    eps = np.array([1.0])
    eps0 = 1.0 / episodes
    rng = np.array([seed_state(seed)], dtype=np.uint64)
    stopped = None
    done, chunk = 0, 2000
    columns = (TextColumn("eps {task.fields[eps]:.3f}"), TextColumn("greedy plan {task.fields[greedy]}"),
               TextColumn("states {task.fields[states]}"))
    with stop_on_interrupt() as flag, progress_bar(progress, *columns) as bar:
        task = bar.add_task(method, total=episodes, eps=1.0, greedy="-", states=0)
        while done < episodes:
            n = min(chunk, episodes - done)
            c0 = time.perf_counter()
            ran, fits = train(model, table, n, eps, eps0, beta, gamma, rng)
            done += ran
            elapsed = time.perf_counter() - c0
            chunk = int(min(max(chunk * min(4.0, 0.25 / max(elapsed, 1e-3)), 100), 200_000))
            idx, sched = rollout(model, table)
            value = simulate_indices(instance, idx, sched).metrics[objective]
            bar.update(task, completed=done, eps=max(float(eps[0]), 0.0), greedy=f"{value:.6g}",
                       states=table.n_states)
            if not fits:
                stopped = (f"Q-table memory limit of {max_memory_mb:g} MiB reached after {done} episodes "
                           f"({table.n_states} states); raise max_memory_mb or lower episodes")
            elif flag.requested:
                stopped = f"interrupted after {done} of {episodes} episodes"
            elif time_limit is not None and time.perf_counter() - t0 > time_limit:
                stopped = f"time limit of {time_limit:g} s reached after {done} of {episodes} episodes"
            if stopped:
                if progress:
                    bar.console.print(f"[yellow]{method}: {stopped}; returning the greedy plan so far")
                break
    idx, sched = rollout(model, table)
    solver = {
        "reward": reward, "reward_units": reward_units, "episodes": episodes, "episodes_run": done, "seed": seed, "beta": beta,
        "gamma": gamma, "epsilon0": eps0, "q_init": q_init, "penalty": penalty,
        "slot_in_state": slot_in_state,
        "table_states": table.n_states, "table_mib": round(table.nbytes / 2**20, 3),
        "startup_s": startup_s,
    }
    if stopped:
        solver["stopped"] = stopped
    return Result.from_plan(
        instance, method, objective, Plan.from_indices(instance, idx, sched),
        status="time_limit" if stopped else "feasible", runtime_s=time.perf_counter() - t0, solver=solver,
    )


def solve(instance: Instance, objective: str = "mean-min-voi", *, progress: bool = False,
          episodes: int = EPISODES, seed: int = 0, beta: float = BETA, gamma: float = GAMMA,
          q_init: float = 0.0, penalty: float = mdp_mod.IDLE_PENALTY, time_limit: float | None = None,
          max_memory_mb: float = 1536, slot_in_state: bool = False, reward_units: str = "bit/s") -> Result:
    """The paper's "VoI-optimal" scheme: Algorithm 1 with reward min_i V_i - idle penalty.

    Options default to the paper's values: V in bit/s and a penalty of 100 (MODEL.md section 7);
    ``reward_units="bit/s/Hz"`` divides V by B, for comparison. ``slot_in_state=True`` (not the
    paper's) adds t to the state; with gamma=1 and penalty=0 Q-learning then targets exactly
    T * mean-min-voi (in reward units)."""
    return _run(instance, objective, "voi", "qlearning", progress=progress, episodes=episodes,
                seed=seed, beta=beta, gamma=gamma, q_init=q_init, penalty=penalty,
                time_limit=time_limit, max_memory_mb=max_memory_mb, slot_in_state=slot_in_state,
                reward_units=reward_units)


def solve_aoi(instance: Instance, objective: str = "mean-max-aoi", *, progress: bool = False,
              episodes: int = EPISODES, seed: int = 0, beta: float = BETA, gamma: float = GAMMA,
              q_init: float = 0.0, penalty: float = mdp_mod.IDLE_PENALTY,
              time_limit: float | None = None, max_memory_mb: float = 1536,
              slot_in_state: bool = False, reward_units: str = "bit/s") -> Result:
    """The paper's "AoI-optimal" scheme: Algorithm 1 with reward -max_i A_i - idle penalty.

    The AoI reward has no units to choose; ``reward_units`` is accepted (and recorded) so that
    a sweep can pass one setting to both Q-learning schemes."""
    return _run(instance, objective, "aoi", "aoi-qlearning", progress=progress, episodes=episodes,
                seed=seed, beta=beta, gamma=gamma, q_init=q_init, penalty=penalty,
                time_limit=time_limit, max_memory_mb=max_memory_mb, slot_in_state=slot_in_state,
                reward_units=reward_units)
