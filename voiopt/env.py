"""A Gymnasium environment over the MDP of models/mdp.py (the ``[rl]`` extra), docs/qlearning.md.

    import gymnasium, voiopt.env
    env = gymnasium.make("voiopt/VoICollection-v0")                 # a paper-style network per reset
    env = gymnasium.make("voiopt/VoICollection-v0", instance=voiopt.load("instances/dock.json"))
    obs, info = env.reset(seed=0, options={"instance": "instances/case-study.json"})

Action: Discrete((N + 1) * 5), number = upload * 5 + move with upload 0 = none, 1 + i =
sensor i, move 0..4 = stay, N, S, E, W. ``action_masks()`` (sb3-contrib's name) and
``info["action_mask"]`` mark the feasible actions: in range, on the area, never onto a blocked
point, and with a way left to ``end`` in the slots and moves left (MODEL.md section 9). An
infeasible action raises ``OptionError`` (``infeasible="raise"``, the default); with
``infeasible="penalise"`` it is executed as its feasible part (no upload, its move if feasible,
else the first move of the way to end), ``penalty`` is subtracted and ``info["infeasible"]``
says so. Nothing is altered silently, and every episode is a legal plan (``plan()``).

Observation, a Dict of float32 arrays in [0, 1] (docs/qlearning.md):
``position`` (2,) = lattice point / area; ``aoi`` (N,) = A_i / (max A_i(0) + T);
``q`` (N,) = q_i / (area diagonal); ``slot`` (1,) = t / T; with ``observe_sensors=True`` also
``sensors`` (N, 2) = positions / area and ``rho`` (N,).

Reward: ``reward_mode="paper"`` (MODEL.md section 7: min_i V_i(t+1) in bit/s, or V/B, or
-max_i A_i(t+1), minus ``penalty`` when nothing is uploaded), or ``"normalised"``: min_i V_i(t+1)
divided by the instance's certified ``mean-min-voi`` optimum (VoI-Lib's certificate when the
instance is in VoI-Lib, else dp's; under lossy links, the optimum without them), no penalty.
Over an episode the (realised) plan's ``mean-min-voi`` is then (sum of rewards + penalty *
infeasible steps) * optimum / T, or, with the paper's VoI reward, (sum of rewards + penalty * (idle slots + infeasible steps)) / T
(``info["idle_slots"]``, ``info["infeasible_steps"]``: 0 unless ``infeasible="penalise"``).

Several robots (MODEL.md section 10): a fleet instance makes a ``FleetVoIEnv``, whose action is
the joint action, Discrete(((N + 1) * 5) ** K), with an exact mask of the legal joint actions
(a MultiDiscrete action's per-robot masks could not rule out two robots choosing one point);
``position`` is then (K, 2) and ``plan()`` a FleetPlan. One agent per robot: voiopt/pz_env.py.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from voiopt.errors import MissingExtraError, OptionError
from voiopt.objectives import Worth

try:
    import gymnasium as gym
    from gymnasium import spaces
except ImportError as e:  # pragma: no cover - depends on the installed extras
    raise MissingExtraError("gymnasium", "rl") from e

from voiopt.core import instance as instance_mod
from voiopt.core.instance import Instance
from voiopt.core.links import without_links
from voiopt.core.plan import Plan
from voiopt.envs.checks import (
    SAMPLE,
    action_in,
    check_normalisable,
    check_sample,
    reset_options,
)
from voiopt.grid import joint
from voiopt.grid import lattice as lattice_mod
from voiopt.mdp import robot as mdp_mod
from voiopt.mdp.outcomes import Outcomes
from voiopt.networks.generate import generate as generate_network
from voiopt.objectives import MEAN_MIN_VOI
from voiopt.runtime.status import Status
from voiopt.viewer import frames

ENV_ID = "voiopt/VoICollection-v0"
REWARD_MODES = ("paper", "normalised")
INFEASIBLE = ("raise", "penalise")
_OPTIMA: dict[Instance, float] = {}  # the normalising optimum of each instance met in this process


class VoIEnv(gym.Env):
    """The entity's slot-by-slot decision (upload, move) with the paper's reward."""

    metadata = {"render_modes": ["ansi", "rgb_array", "human"], "render_fps": 4}

    def __init__(self, instance: Instance | None = None, reward: str = "voi", render_mode: str | None = None,
                 penalty: float = mdp_mod.IDLE_PENALTY, reward_units: str = "bit/s", reward_mode: str = "paper",
                 infeasible: str = "raise", observe_sensors: bool = False, sample: dict | None = None):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise OptionError(f"render_mode: must be 'ansi', 'rgb_array' or 'human', got {render_mode!r}")
        if reward_mode not in REWARD_MODES:
            raise OptionError(f"reward_mode: must be 'paper' or 'normalised', got {reward_mode!r}")
        if reward_mode == "normalised" and reward != Worth.VOI:
            raise OptionError(f"reward_mode: 'normalised' divides the VoI reward by the mean-min-voi optimum; "
                              f"with reward={reward!r} use reward_mode='paper'")
        if infeasible not in INFEASIBLE:
            raise OptionError(f"infeasible: must be 'raise' or 'penalise', got {infeasible!r}")
        if not isinstance(observe_sensors, (bool, np.bool_)):  # "no" would be true
            raise OptionError(f"observe_sensors: must be True or False, got {observe_sensors!r}")
        self.render_mode = render_mode
        self._painter = self._window = None
        self.options = dict(reward=reward, penalty=penalty, reward_units=reward_units)
        self.reward_mode, self.infeasible, self.observe_sensors = reward_mode, infeasible, bool(observe_sensors)
        if instance is not None and sample is not None:
            raise OptionError("sample: draws the networks of an env without an instance; got instance= as well")
        self.sample = None if instance is not None else {**SAMPLE, **check_sample(sample)}
        self._started = False  # by reset(): a step before it is refused (gymnasium.make's wrapper does the same)
        given = self.__dict__.pop("_given", None)
        if given is None and instance is not None:
            given = instance_mod.as_instance(instance, "instance")
        self._load(given if given is not None else generate_network(seed=0, **self.sample))
        lat, N, K = self.lattice, self.instance.n_sensors, self.instance.n_robots
        box = lambda *shape: spaces.Box(0.0, 1.0, shape=shape, dtype=np.float32)  # noqa: E731
        obs = {"position": box(K, 2) if self.instance.fleet else box(2), "aoi": box(N), "q": box(N), "slot": box(1)}
        if self.observe_sensors:
            obs.update(sensors=box(N, 2), rho=box(N))
        self.observation_space = spaces.Dict(obs)
        self.action_space = spaces.Discrete(((N + 1) * 5) ** K)
        self._shape = (N, lat.nx, lat.ny, self.instance.horizon)

    def __new__(cls, instance: Instance | None = None, *args, **kwargs):
        """A fleet instance (MODEL.md section 10) makes a FleetVoIEnv: the joint action."""
        given = None if instance is None else instance_mod.as_instance(instance, "instance")
        env = super().__new__(FleetVoIEnv if given is not None and given.fleet else cls)
        env._given = given  # a path is loaded once, here, and __init__ takes it from here
        return env

    # ------------------------------------------------------------------ the instance

    def _load(self, instance: Instance) -> None:
        if self.reward_mode == "normalised":
            check_normalisable(instance)
        self.instance = instance
        self.model = mdp_mod.build(instance, self.options["reward"], self.options["penalty"],
                                   reward_units=self.options["reward_units"])
        self.lattice = lat = lattice_mod.build(instance)
        self._outcomes = Outcomes(instance)  # MODEL.md section 11: upload outcomes, drawn only when lossy
        N = instance.n_sensors
        self._local = np.full((lat.n_points, (N + 1) * 5), -1, dtype=np.int64)  # global -> per-point action
        for p in range(lat.n_points):
            for k, (u, m) in enumerate(self.model.actions(p)):
                self._local[p, (u + 1) * 5 + m] = k
        self._ready(instance)

    def _penalise(self, reward: float, feasible: bool) -> float:
        """An infeasible action executed as its feasible part pays ``penalty`` (and is counted)."""
        if feasible:
            return reward
        self._penalised += 1
        return reward - self.options["penalty"]

    def _ready(self, instance: Instance) -> None:
        """What every env sets last: the scales of its observation, and a first episode."""
        self._max_age = float(self.model.initial_aoi.max() + instance.horizon)
        self._diagonal = math.hypot(instance.width, instance.height)
        self._optimum = None
        self._restart()

    def _restart(self) -> None:
        self.state, self.t = self.model.initial_state(), 0
        self._positions: list = []
        self._schedule: list = []
        self._idle = 0
        self._penalised = 0  # steps executed as their feasible part, ``penalty`` subtracted

    def optimum(self) -> float:
        """The certified mean-min-voi optimum that normalises the reward (once per instance)."""
        if self._optimum is None:
            from voiopt.solvers import solve
            from voiopt.voilib import library as voilib

            if self.instance not in _OPTIMA:
                lossless = without_links(self.instance)  # lossy links: the lossless optimum, a bound on every policy
                cert = voilib.certified(lossless, MEAN_MIN_VOI)
                if cert is None:
                    result = solve(lossless, "dp", MEAN_MIN_VOI, progress=True)
                    if result.status != Status.OPTIMAL:
                        raise OptionError(f"reward_mode: 'normalised' needs a proven optimum, and dp stopped on "
                                          f"{self.instance.name} ({result.status}); use 'paper'")
                    cert = result.value
                _OPTIMA[self.instance] = cert
            self._optimum = _OPTIMA[self.instance]
        return self._optimum

    # ------------------------------------------------------------------ gymnasium API

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = reset_options(options)
        unknown = set(options) - {"instance"}
        if unknown:
            raise OptionError(f"options: unknown key {sorted(unknown)[0]!r} (allowed: instance)")
        if "instance" in options:
            inst = instance_mod.as_instance(options["instance"], "options.instance")
            self._check_fits(inst)
            self._load(inst)
        elif self.sample is not None:  # a fresh paper-style network from the env's own generator
            self._load(generate_network(seed=int(self.np_random.integers(2**63)), **self.sample))
        else:
            self._restart()
        self._started = True
        return self._obs(), self._info()

    def _check_fits(self, inst: Instance) -> None:
        if inst.n_robots != self.instance.n_robots:
            raise OptionError(f"options.instance: {inst.name} has {inst.n_robots} robot(s); this env's spaces are for "
                              f"{self.instance.n_robots} (make a new env with instance=...)")
        lat = lattice_mod.build(inst)
        if (inst.n_sensors, lat.nx, lat.ny, inst.horizon) != self._shape:
            N, nx, ny, T = self._shape
            raise OptionError(f"options.instance: {inst.name} has N={inst.n_sensors}, a {lat.nx} x {lat.ny} lattice and "
                              f"T={inst.horizon}; this env's spaces are for N={N}, {nx} x {ny}, T={T} "
                              "(make a new env with instance=...)")

    def action_masks(self) -> np.ndarray:
        """Bool mask over the Discrete actions (sb3-contrib's MaskablePPO calls this)."""
        local = self._local[self.state[0]]
        mask = local >= 0
        if self.t >= self.instance.horizon:  # the episode has ended: no action (as a fleet's)
            return np.zeros_like(mask)
        mask[mask] = self.model.feasible(self.state, self.t)[local[mask]]
        return mask

    action_mask = action_masks

    def _check_action(self, action) -> int:
        """The action as an int; raises if it is outside the space or the episode has ended."""
        a = action_in(action, self.action_space.n)
        if not self._started:
            raise OptionError("step: no episode has started: call reset() first")
        if self.t >= self.instance.horizon:
            raise OptionError(f"step: the episode has ended (slot {self.t} of {self.instance.horizon}): call reset()")
        return a

    def step(self, action):
        a = self._check_action(action)
        p = self.state[0]
        mask = self.action_masks()
        feasible = bool(mask[a])
        if not feasible and self.infeasible == "raise":
            raise OptionError(f"action {a} ({f'upload sensor {a // 5 - 1}' if a >= 5 else 'no upload'}, move {a % 5}) "
                              f"is infeasible in "
                              f"slot {self.t} (see action_masks())")
        k = int(self._local[p, a])
        if not feasible:  # penalised: no upload, the move if feasible, else the first move of the way to end
            move = a % 5
            if not mask[move]:
                home = self.lattice.walk_home(p, 1)[0]
                move = self.lattice.move(p, home)
            k = int(self._local[p, move])
        u = int(self.model.action_upload[p, k])
        outcome = self._outcomes.draw(self.np_random, [p], [u])
        if Outcomes.failed(outcome):  # a failed upload acts as no upload, with the same move
            k = int(self._local[p, a % 5])
        self._positions.append(p)
        self._schedule.append(u)
        self._idle += u < 0
        self.state, reward = self.model.step(self.state, k)
        reward = Outcomes.refunded(reward, outcome, self.options["penalty"])
        if self.reward_mode == "normalised":
            _, aoi, qidx, *_ = self.state
            reward = min(float(self.model.voi_reward[i, a_, q]) for i, (a_, q) in enumerate(zip(aoi, qidx, strict=True)))
            if self.options["reward_units"] == "bit/s/Hz":
                reward *= self.instance.channel.bandwidth_hz
            reward /= self.optimum()
        reward = self._penalise(reward, feasible)
        self.t += 1
        terminated = self.t >= self.instance.horizon
        info = self._info() | self._outcomes.info(outcome)
        info["infeasible"] = not feasible
        return self._obs(), float(reward), terminated, False, info

    def plan(self) -> Plan:
        """The episode's plan so far (a whole plan, which ``voiopt evaluate`` scores, after T steps)."""
        return Plan.from_indices(self.instance, self._positions, self._schedule)

    def _points(self) -> list[int]:
        """The robot's point (each robot's, for a fleet)."""
        return [self.state[0]]

    def _distances(self, qidx) -> np.ndarray:
        """q_i(t) of every sensor from the state's distance indices (0: the initial distance)."""
        lat = self.lattice
        return np.array([self.instance.initial_distance(i) if q == 0 else lat.distance[i, q - 1]
                         for i, q in enumerate(qidx)])

    def _obs(self) -> dict[str, np.ndarray]:
        _, aoi, qidx, *_ = self.state
        inst, lat = self.instance, self.lattice
        dist = self._distances(qidx)
        position = lat.points[self._points()] / [inst.width, inst.height]
        obs = {
            "position": position.reshape(self.observation_space["position"].shape).astype(np.float32),
            "aoi": np.clip(np.asarray(aoi) / self._max_age, 0, 1).astype(np.float32),
            "q": np.clip(dist / self._diagonal, 0, 1).astype(np.float32),
            "slot": np.array([self.t / inst.horizon], dtype=np.float32),
        }
        if self.observe_sensors:
            pos = np.array([s.position for s in inst.sensors])
            obs["sensors"] = (pos / [inst.width, inst.height]).astype(np.float32)
            obs["rho"] = np.array([s.rho for s in inst.sensors], dtype=np.float32)
        return obs

    def _info(self) -> dict[str, Any]:
        return {"action_mask": self.action_masks(), "slot": self.t, "idle_slots": self._idle,
                "infeasible_steps": self._penalised, "instance": self.instance.name}

    # ------------------------------------------------------------------ rendering

    def render(self):
        if self.render_mode == "ansi":
            return self._ansi()
        if self.render_mode == "rgb_array":
            return self._rgb()
        if self.render_mode == "human":  # a window; where none can open, a warning once and nothing
            self._human()
        return None

    def _ansi(self) -> str:
        """The lattice, top row first: R the robot, # blocked, D the end (dock), i the nearest
        point of sensor i (mod 10), . a free point; then each sensor's position, rho and AoI."""
        lat, inst, points = self.lattice, self.instance, self._points()
        cells = np.full(lat.n_points, ".", dtype=object)
        cells[lat.blocked] = "#"
        if lat.end >= 0:
            cells[lat.end] = "D"
        for i in range(inst.n_sensors):
            cells[int(np.argmin(lat.distance[i]))] = str(i % 10)
        for k, p in enumerate(points):  # R for one robot, A, B, ... for a fleet
            cells[p] = "R" if len(points) == 1 else chr(ord("A") + k % 26)
        rows = [" ".join(cells[k * lat.ny + l] for k in range(lat.nx)) for l in reversed(range(lat.ny))]
        _, aoi, *_ = self.state
        rows.append(f"slot {self.t}/{inst.horizon}")
        rows += [f"sensor {i} at ({s.position[0]:g}, {s.position[1]:g}) rho {s.rho:.2f} AoI {a}"
                 for i, (s, a) in enumerate(zip(inst.sensors, aoi, strict=True))]
        return "\n".join(rows) + "\n"

    def _rgb(self) -> np.ndarray:
        """The current slot as voiopt.viewer.frames draws it: a (H, W, 3) uint8 array of one
        fixed shape (frames.SIZE_PX), whatever the instance."""
        if self._painter is None or self._painter.instance is not self.instance:
            self._painter = frames.Painter(self.instance, self.instance.name)
        return self._painter.rgb(self.current_slot())

    def current_slot(self) -> frames.Slot:
        """What render() draws: slot t, each robot's points p(0..t) and uploads u(0..t-1), and V_i(t), A_i(t)."""
        _, aoi, qidx, *_ = self.state
        inst = self.instance
        dist = self._distances(qidx)
        paths, uploads = (self._positions, self._schedule) if inst.fleet else ([self._positions], [self._schedule])
        return frames.from_points(inst, self.t, [[*path, p] for path, p in zip(paths, self._points(), strict=True)],
                                  [[*up, -1] for up in uploads], aoi, dist)

    def _human(self) -> None:
        self._window = self._window or frames.Window(self.metadata["render_fps"])
        self._window.show(self._rgb())

    def close(self) -> None:
        if getattr(self, "_window", None) is not None:
            self._window.close()
            self._window = None
        super().close()


MAX_JOINT_ACTIONS = 1 << 22  # the longest joint action mask a FleetVoIEnv offers


class FleetVoIEnv(VoIEnv):
    """Several robots (MODEL.md section 10): one joint decision per slot, every robot's (upload,
    move). Action: Discrete(((N + 1) * 5) ** K), the number sum_k a_k * ((N + 1) * 5) ** (K - 1 - k)
    with a_k robot k's one-robot action number (robot 0 most significant; ``joint_action``
    builds it). ``action_masks()`` marks exactly the legal joint actions (models/fleet_mdp.py):
    no shared point, no swap, a sensor to at most one robot, and a way for all robots together
    to keep every robot's section-9 rules. An illegal joint action raises, or with
    ``infeasible="penalise"`` is executed as the requested moves without uploads if that is
    legal, else as the first legal joint action, minus ``penalty``. Reward: MODEL.md sections 7
    and 10 (the penalty once per robot that uploads nothing); ``reward_mode="paper"`` only."""

    def __init__(self, instance: Instance, *args, **kwargs):
        super().__init__(instance, *args, **kwargs)
        if self.reward_mode != "paper":
            raise OptionError("reward_mode: a fleet has no certified optimum to normalise by; use 'paper'")

    def _load(self, instance: Instance) -> None:
        from voiopt.mdp import fleet as fleet_mdp

        N, K = instance.n_sensors, instance.n_robots
        A = (N + 1) * 5
        if A**K > MAX_JOINT_ACTIONS:
            raise OptionError(f"instance: {K} robots among {N} sensors have {A}^{K} = {A**K} joint actions, over the "
                              f"{MAX_JOINT_ACTIONS} a joint action mask may have")
        self.instance = instance
        self.joint = fleet_mdp.build(instance, self.options["reward"], self.options["penalty"],
                                     reward_units=self.options["reward_units"])
        self.model = self.joint.one
        self.lattice = lattice_mod.build(instance)
        self._outcomes = Outcomes(instance)
        self._global = np.array([[(u + 1) * 5 + m for u, m in self.model.actions(p)] + [-1] * (self.model.max_actions
                                 - int(self.model.n_actions[p])) for p in range(self.lattice.n_points)], dtype=np.int64)
        self._ready(instance)

    def _restart(self) -> None:
        K = self.instance.n_robots
        self.state, self.t = self.joint.initial_state(), 0
        self._positions, self._schedule = [[] for _ in range(K)], [[] for _ in range(K)]
        self._idle = 0
        self._penalised = 0  # steps executed as their feasible part, ``penalty`` subtracted

    def _points(self) -> list[int]:
        return list(self.state[0])

    def joint_action(self, actions) -> int:
        """The Discrete number of per-robot actions (each upload * 5 + move, upload 0 = none)."""
        return joint.number(actions, (self.instance.n_sensors + 1) * 5)

    def split_action(self, action: int) -> list[int]:
        """Per-robot actions (upload * 5 + move) of a joint Discrete number."""
        A, out = (self.instance.n_sensors + 1) * 5, []
        for _ in range(self.instance.n_robots):
            out.append(int(action) % A)
            action = int(action) // A
        return out[::-1]

    def _env_number(self, j: int) -> int:
        points = self.state[0]
        return self.joint_action(self._global[p, a] for p, a in zip(points, self.joint.split(points, j), strict=True))

    def action_masks(self) -> np.ndarray:
        """Bool mask over the Discrete joint actions: exactly the legal ones."""
        mask = np.zeros(self.action_space.n, dtype=bool)
        if self.t < self.instance.horizon:
            mask[[self._env_number(j) for j in self.joint.legal(self.state, self.t)]] = True
        return mask

    action_mask = action_masks

    def _mdp_number(self, actions) -> int | None:
        """The joint action number of models/fleet_mdp.py, or None if some robot's action does
        not exist at its point (off the area, onto a blocked point, a sensor out of range)."""
        j = 0
        for p, a in zip(self.state[0], actions, strict=True):
            hit = np.flatnonzero(self._global[p] == a)
            if not len(hit):
                return None
            j = j * int(self.model.n_actions[p]) + int(hit[0])
        return j

    def step(self, action):
        a = self._check_action(action)
        legal = self.joint.legal(self.state, self.t)
        j = self._mdp_number(self.split_action(a))
        feasible = j in legal
        if not feasible:
            if self.infeasible == "raise":
                raise OptionError(f"joint action {a} (robots' actions {self.split_action(a)}) is illegal in slot "
                                  f"{self.t} (see action_masks())")
            j = self._mdp_number([m % 5 for m in self.split_action(a)])
            j = j if j in legal else legal[0]
        points = self.state[0]
        for k, (p, b) in enumerate(zip(points, self.joint.split(points, j), strict=True)):
            u = int(self.model.action_upload[p, b])
            self._positions[k].append(p)
            self._schedule[k].append(u)
            self._idle += u < 0
        outcome = self._outcomes.draw(self.np_random, points, [s[-1] for s in self._schedule])
        if Outcomes.failed(outcome):  # each failed upload acts as its robot's move alone
            j = self._mdp_number([m % 5 if ok is False else m for m, ok in zip(self.split_action(self._env_number(j)), outcome, strict=True)])
        self.state, reward = self.joint.step(self.state, j)
        reward = Outcomes.refunded(reward, outcome, self.options["penalty"])
        reward = self._penalise(reward, feasible)
        self.t += 1
        info = self._info() | self._outcomes.info(outcome)
        info["infeasible"] = not feasible
        return self._obs(), float(reward), self.t >= self.instance.horizon, False, info


if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="voiopt.env:VoIEnv", max_episode_steps=None)
