"""The MDP of several robots (MODEL.md section 10) for Q-learning and the environments.

State: every robot's point, then what the one-robot state of models/mdp.py holds (A, q as
distance indices, the slot if asked, the moves made by each robot whose budget binds).
Action: the joint action, one action number of models/mdp.py per robot (each robot's actions
at its point are those of the one-robot MDP: the lattice, the sensors and the ranges are the
same for every robot), numbered as a mixed-radix integer with robot 0's action most
significant. Legal joint actions: no two robots on the same next point, no swap, no sensor
uploading to two robots, and, when a robot has an ``end`` or a binding ``max_moves``, next
points from which all robots together can still finish legally (``alive``, computed backwards
over the joint points, exact: a robot can be trapped by another one, not only by its own
rules). In the last slot only the conflicts are masked (p(T) is not part of a plan).
Reward r_{t+1} = min_i V_i(t+1) - penalty * (robots that upload nothing), or the AoI one.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from voiopt.core.instance import Instance
from voiopt.core.simulate import advance
from voiopt.grid import joint
from voiopt.grid import lattice as lattice_mod
from voiopt.mdp import robot as mdp_mod

MAX_JOINT_ACTIONS = 1 << 16  # the Q-table keeps a state's greedy action in 16 bits


@dataclass(frozen=True, eq=False)
class FleetMDP:
    one: mdp_mod.MDP  # robot 0's one-robot MDP: the action arrays and the reward table
    n_robots: int
    starts: np.ndarray  # (K,) lattice index of each robot's p(0)
    budgets: np.ndarray  # (K,) each robot's min(max_moves, T - 1)
    counted: np.ndarray  # (K,) bool: the robot's moves are part of the state (its budget binds)
    alive: np.ndarray  # (T - alive_first, n**K, M) uint8 (joint.Table), or (1, 1, 1) ones when nothing is masked
    alive_first: int  # slot t's row of alive is max(t - alive_first, 0)
    moves_radix: np.ndarray  # (K,) budget + 2 for counted robots, 1 for the others
    masked: bool  # some robot has an end or a binding budget
    field_word: np.ndarray
    field_shift: np.ndarray
    field_width: np.ndarray
    n_words: int

    # what QTable asks of a model
    @property
    def horizon(self) -> int:
        return self.one.horizon

    @property
    def n_sensors(self) -> int:
        return self.one.n_sensors

    @property
    def instance(self) -> Instance:
        return self.one.instance

    @property
    def max_actions(self) -> int:
        return int(self.one.n_actions.max()) ** self.n_robots

    @property
    def n_actions(self) -> np.ndarray:  # a typical row length, for the pool's first size
        return np.array([float(self.one.n_actions.mean()) ** self.n_robots])

    def joint_count(self, points) -> int:
        return int(np.prod([int(self.one.n_actions[p]) for p in points]))

    def split(self, points, j: int) -> list[int]:
        """The per-robot action numbers of joint action j at the robots' points."""
        out = []
        for p in reversed(points):
            n = int(self.one.n_actions[p])
            out.append(j % n)
            j //= n
        return out[::-1]

    def initial_state(self):
        """(points, A(0), q(0) indices, slot, moves of each robot)."""
        K = self.n_robots
        return (tuple(int(p) for p in self.starts), tuple(int(a) for a in self.one.initial_aoi),
                (0,) * self.n_sensors, 0, (0,) * K)

    def _alive(self, t: int, points, moves) -> bool:
        if not self.masked or t >= self.horizon:
            return True
        if any(m > b for m, b in zip(moves, self.budgets.tolist(), strict=True)):
            return False
        n, c, mi = self.one.n_actions.shape[0], 0, 0
        for p, m, r, cnt in zip(points, moves, self.moves_radix.tolist(), self.counted.tolist(), strict=True):
            c = c * n + p
            mi = mi * r + (m if cnt else 0)
        return bool(self.alive[max(t - self.alive_first, 0), c, mi])

    @cached_property
    def _point_actions(self) -> list[list[tuple[int, int]]]:
        """(next point, upload) of each action number at each point, as Python ints."""
        one = self.one
        return [list(zip(one.action_next[p, :k].tolist(), one.action_upload[p, :k].tolist(), strict=True))
                for p, k in enumerate(one.n_actions.tolist())]

    def legal(self, state, t: int) -> list[int]:
        """The legal joint action numbers in slot t, ascending (MODEL.md section 10)."""
        points, moves = state[0], self.moves_made(state)
        out = []
        rows = [self._point_actions[p] for p in points]
        for j, combo in enumerate(itertools.product(*rows)):  # robot 0 most significant, as split()
            nxt = [q for q, _ in combo]
            if conflict(points, nxt, [u for _, u in combo]):
                continue
            if t + 1 < self.horizon and self.masked:
                used = tuple(m + (q != p) for m, q, p in zip(moves, nxt, points, strict=True))
                if not self._alive(t + 1, nxt, used):
                    continue
            out.append(j)
        return out

    def moves_made(self, state) -> tuple[int, ...]:
        return tuple(int(m) if c else 0 for m, c in zip(state[4], self.counted.tolist(), strict=True))

    def step(self, state, j: int):
        """(next state, reward) after joint action j; plain Python, for the envs and the reference."""
        points, aoi, qidx, slot, moves = state
        one = self.one
        acts = self.split(points, j)
        nxt = tuple(int(one.action_next[p, a]) for p, a in zip(points, acts, strict=True))
        up = [int(one.action_upload[p, a]) for p, a in zip(points, acts, strict=True)]
        a, q = advance(np.array(aoi, np.int64), np.array(qidx, np.int64), up, [1 + p for p in points])
        aoi, qidx = tuple(a.tolist()), tuple(q.tolist())
        slot = slot + 1 if one.slot_in_state else 0
        moves = tuple(m + (b != p) if c else 0
                      for m, b, p, c in zip(moves, nxt, points, self.counted.tolist(), strict=True))
        return (nxt, aoi, qidx, slot, moves), self.reward_of(aoi, qidx, sum(u < 0 for u in up))

    def reward_of(self, aoi, qidx, idle: int) -> float:
        """r_{t+1}: the one-robot reward with the penalty once per robot that uploads nothing."""
        one = self.one
        if one.reward == "aoi":
            r = -float(max(aoi))
        else:
            r = min(float(one.voi_reward[i, a, q]) for i, (a, q) in enumerate(zip(aoi, qidx, strict=True)))
        return r - one.penalty * idle

    def fields(self, state) -> list[int]:
        points, aoi, qidx, slot, moves = state
        values = list(points)
        for a, q in zip(aoi, qidx, strict=True):
            values += [a, q]
        values.append(slot)
        values += [m for m, c in zip(moves, self.counted.tolist(), strict=True) if c]
        return values

    def encode(self, state) -> np.ndarray:
        words = [0] * self.n_words
        for f, v in enumerate(self.fields(state)):
            words[self.field_word[f]] |= int(v) << int(self.field_shift[f])
        return np.array(words, dtype=np.uint64)

    def decode(self, words):
        values = [(int(words[w]) >> int(s)) & ((1 << int(b)) - 1)
                  for w, s, b in zip(self.field_word, self.field_shift, self.field_width, strict=True)]
        K, N = self.n_robots, self.n_sensors
        points, rest = tuple(values[:K]), values[K:]
        counted = iter(rest[2 * N + 1:])
        moves = tuple(next(counted) if c else 0 for c in self.counted.tolist())
        return points, tuple(rest[0:2 * N:2]), tuple(rest[1:2 * N:2]), rest[2 * N], moves


def conflict(points, nxt, up) -> bool:
    """The rules between robots of MODEL.md section 10 for one slot's joint action."""
    for k in range(1, len(points)):
        for j in range(k):
            if nxt[k] == nxt[j] or (nxt[k] == points[j] and nxt[j] == points[k]) or (up[k] >= 0 and up[k] == up[j]):
                return True
    return False


def alive_bytes(instance: Instance) -> float:
    """The bytes the joint mask ``alive`` needs at least (0 when no robot has an end or a
    binding budget): two slots, the last and the one being filled. It grows a slot at a time,
    under the memory limit's watch, until a slot equals the next, which seldom takes more than a
    few dozen (joint.table); T slots are the most it can hold."""
    T = instance.horizon
    radix = joint.budgets([r.max_moves for r in instance.robots], T)[2]
    if not any(r.end is not None for r in instance.robots) and all(x == 1 for x in radix):
        return 0.0
    return joint.entries(lattice_mod.n_points(instance), instance.n_robots, min(T, 2), radix)


def _budgets(instance: Instance, lats) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Each robot's move budget, whether it binds (counted in the state), and the radix of
    its moves-made digit (joint.budgets)."""
    return joint.budgets([lat.budget for lat in lats], instance.horizon)


def _alive_table(instance: Instance, lats, stop=None) -> joint.Table:
    return joint.table(lats[0].neighbors, [lat.end for lat in lats], [lat.budget for lat in lats], instance.horizon,
                       stop)


LEGAL_PATHS_CELLS = joint.CELLS


def legal_paths(instance: Instance) -> np.ndarray | None:
    """(K, T) points of a legal joint plan of a fleet, found exactly: a walk forward from the
    starts through the table of joint states that can still keep every rule to the last slot
    (joint.walk). Raises NoJointPlan when the starts cannot (a proof that no legal plan
    exists); None where the tables would pass LEGAL_PATHS_CELLS entries (then nothing is
    decided)."""
    K, T = instance.n_robots, instance.horizon
    n = lattice_mod.n_points(instance)
    lats = [lattice_mod.build(instance.robot(k)) for k in range(K)]
    if joint.cells(n, K, T, _budgets(instance, lats)[2]) > LEGAL_PATHS_CELLS:
        return None
    paths = joint.walk(_alive_table(instance, lats), [lat.start for lat in lats])
    if paths is None:
        raise joint.NoJointPlan(_no_joint_plan(instance))
    return paths


def _no_joint_plan(instance: Instance) -> str:
    return (f"robots: no joint plan keeps the rules between robots and every robot's end and max_moves in "
            f"{instance.name} (MODEL.md section 10)")


def build(instance: Instance, reward: str = "voi", penalty: float = mdp_mod.IDLE_PENALTY,
          slot_in_state: bool = False, reward_units: str = "bit/s", stop=None) -> FleetMDP:
    """The joint MDP of a fleet instance (K >= 2 robots); voiopt.runtime.stop.Stopped if ``stop`` says
    stop while its tables (VoI, legal joint states) are built."""
    K = instance.n_robots
    one = mdp_mod.build(instance.robot(0), reward, penalty, slot_in_state, reward_units, stop)
    lats = [lattice_mod.build(instance.robot(k)) for k in range(K)]
    budgets, counted, radix = _budgets(instance, lats)
    masked = bool(counted.any() or any(lat.end >= 0 for lat in lats))
    if masked:
        tab = _alive_table(instance, lats, stop)
        alive, alive_first = tab.alive, tab.first
    else:
        alive, alive_first = np.ones((1, 1, 1), dtype=np.uint8), instance.horizon
    starts = np.array([lat.start for lat in lats], dtype=np.int64)
    fleet = FleetMDP(one, K, starts, budgets, counted, alive, alive_first, np.array(radix, dtype=np.int64), masked,
                     *_packing(one, K, counted, budgets))
    if not fleet._alive(0, tuple(starts.tolist()), (0,) * K):
        raise joint.NoJointPlan(_no_joint_plan(instance))
    for a in (starts, budgets, counted, alive):
        a.setflags(write=False)
    return fleet


def _packing(one: mdp_mod.MDP, K: int, counted, budgets):
    """Field words, shifts and widths: K points, (A_i, q_i) per sensor, the slot, counted moves."""
    n, N, T = one.n_actions.shape[0], one.n_sensors, one.horizon
    max_age = int(one.initial_aoi.max()) + T
    bits = mdp_mod.bits_for
    widths = [bits(n - 1)] * K + [bits(max_age), bits(n)] * N + [bits(T)]
    widths += [bits(int(b) + 1) for b, c in zip(budgets, counted, strict=True) if c]
    field_word, field_shift, n_words = mdp_mod.pack(widths)
    return field_word, field_shift, np.array(widths, dtype=np.int64), n_words


def sizes(instance: Instance, first_states: int) -> dict[str, float]:
    """What the joint Q-learning of a fleet allocates before its first episode, without building
    it: ``joint_actions`` (the longest Q row: the product of the robots' action counts at the
    points with the most sensors in range), ``joint_points`` (n**K), and ``bytes``: the joint
    mask and its move tables, the reward table and a first hash table of ``first_states`` states
    with one episode's rows to spare."""
    K, N, T = instance.n_robots, instance.n_sensors, instance.horizon
    lat = lattice_mod.build(instance)
    per_point = int((lat.in_range.sum(axis=0).max() + 1) * 5)
    joint = float(per_point) ** K
    configs = float(lat.n_points) ** K
    mask = alive_bytes(instance)
    moves_tables = configs * 5.0**K * (8 + K + 8.0 * K / 5.0**K) if mask else 0.0  # next points, moved, configs
    words = 2 * N + 2 * K + 3  # an upper bound on the packed key's words plus the slot's two
    reward_table = 8.0 * N * (max(s.initial_aoi for s in instance.sensors) + T + 1) * (lat.n_points + 1)
    table = 8.0 * first_states * words + 8.0 * (0.7 * first_states + T + 1) * joint
    return {"joint_actions": joint, "joint_points": configs, "bytes": mask + moves_tables + reward_table + table,
            "per_robot_actions": per_point}
