"""A PettingZoo ParallelEnv over the Gymnasium env of env.py (the ``[rl]`` extra): one agent per
robot, ``robot_0``, ``robot_1``, ... (MODEL.md section 10), docs/qlearning.md.

    from voiopt.pz_env import parallel_env
    env = parallel_env(instance=voiopt.load("fleet.json"))
    obs, infos = env.reset(seed=0)
    actions = {a: int(np.flatnonzero(obs[a]["action_mask"])[0]) for a in env.agents}
    obs, rewards, terminations, truncations, infos = env.step(actions)

Each agent's action is its robot's one-robot action, Discrete((N + 1) * 5), upload * 5 + move
(upload 0 = none, 1 + i = sensor i; move 0..4 = stay, N, S, E, W). Each agent's observation is
a Dict: the shared state (``robots``, every robot's point, index order; ``aoi``, ``q``,
``slot``; ``sensors`` and ``rho`` with ``observe_sensors=True``), its own ``position``, and
``action_mask`` (int8): the actions of this robot that belong to some legal joint action.

Agents choose at once, so their choices may conflict (two robots onto one point, a swap, one
sensor to two robots, or a way to the ends that no longer exists). Conflicts are resolved
deterministically in agent order: robot 0's action stands if it is in its mask; robot k's
action stands if some legal joint action extends the actions standing for robots 0..k-1 and
it; otherwise it is replaced by the same move without an upload if that extends them, else by
the first action (lowest number) that does. Every agent's reward is the team's reward of
MODEL.md sections 7 and 10 (the penalty once per robot that uploads nothing), and a replaced
agent's own reward is that less ``penalty`` (the others' are not reduced): its info says
``"replaced": true`` with the action executed. The executed joint action is always legal, so
``plan()`` is always a legal plan. An action that is missing, not an integer or outside the
agent's space is refused (OptionError), as is a step outside an episode. All agents end
together after T steps. On a lossy instance (MODEL.md section 11) each agent's info holds its
robot's ``upload_success`` (True, False, or None where it uploaded nothing), drawn by the env
with its seed (voiopt.mdp.outcomes).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from voiopt.errors import MissingExtraError, OptionError

try:
    from gymnasium import spaces
    from pettingzoo import ParallelEnv
except ImportError as e:  # pragma: no cover - depends on the installed extras
    raise MissingExtraError(e.name or "pettingzoo", "rl") from e

from voiopt.core.instance import Instance
from voiopt.core.plan import FleetPlan, Plan
from voiopt.env import VoIEnv
from voiopt.envs.checks import action_in, reset_options
from voiopt.mdp import robot as mdp_mod


class VoIParallelEnv(ParallelEnv):
    """One agent per robot over VoIEnv's joint decision; see the module's docstring."""

    metadata = {"render_modes": ["ansi", "rgb_array", "human"], "name": "voiopt_fleet_v0", "is_parallelizable": True}

    def __init__(self, instance: Instance, reward: str = "voi", render_mode: str | None = None,
                 penalty: float = mdp_mod.IDLE_PENALTY, reward_units: str = "bit/s", observe_sensors: bool = False):
        self.env = VoIEnv(instance, reward=reward, render_mode=render_mode, penalty=penalty,
                          reward_units=reward_units, observe_sensors=observe_sensors)
        self.render_mode = render_mode
        self.penalty = float(penalty)
        K, N = instance.n_robots, instance.n_sensors
        self.possible_agents = [f"robot_{k}" for k in range(K)]
        self.agents: list[str] = []
        self._n = (N + 1) * 5
        shared = self.env.observation_space.spaces
        box = lambda *shape: spaces.Box(0.0, 1.0, shape=shape, dtype=np.float32)  # noqa: E731
        obs = {"position": box(2), "robots": box(K, 2), **{k: v for k, v in shared.items() if k != "position"},
               "action_mask": spaces.Box(0, 1, shape=(self._n,), dtype=np.int8)}
        self._observation_space = spaces.Dict(obs)
        self._action_space = {a: spaces.Discrete(self._n) for a in self.possible_agents}

    @property
    def instance(self) -> Instance:
        return self.env.instance

    def observation_space(self, agent: str) -> spaces.Dict:
        return self._observation_space

    def action_space(self, agent: str) -> spaces.Discrete:
        return self._action_space[agent]

    # ------------------------------------------------------------------ joint actions

    def _split(self, joint: int) -> tuple[int, ...]:
        out = []
        for _ in self.possible_agents:
            out.append(joint % self._n)
            joint //= self._n
        return tuple(out[::-1])

    def _join(self, actions) -> int:
        out = 0
        for a in actions:
            out = out * self._n + int(a)
        return out

    def _legal(self) -> list[tuple[int, ...]]:
        """The legal joint actions as per-robot action tuples, from the Gym env's exact mask."""
        return [self._split(int(j)) for j in np.flatnonzero(self.env.action_masks())]

    def _resolve(self, actions: dict[str, Any]) -> tuple[tuple[int, ...], list[bool]]:
        """The executed joint action and which agents' actions were replaced (module docstring)."""
        legal = self._legal()
        prefixes = {t[:k] for t in legal for k in range(1, len(t) + 1)}
        kept: tuple[int, ...] = ()
        replaced = []
        for agent in self.possible_agents:
            a = self._check(actions, agent)
            if kept + (a,) in prefixes:
                kept, swap = kept + (a,), False
            else:
                stay = a % 5
                choice = stay if kept + (stay,) in prefixes else min(x for x in range(self._n) if kept + (x,) in prefixes)
                kept, swap = kept + (choice,), True
            replaced.append(swap)
        return kept, replaced

    def _check(self, actions: dict[str, Any], agent: str) -> int:
        """The agent's action as an int in its space: one that is missing, of another type or
        out of range is refused (OptionError), not replaced as a conflict would be."""
        if agent not in actions:
            raise OptionError(f"actions: no action for {agent!r} (every agent acts in every slot)")
        return action_in(actions[agent], self._n, f"actions[{agent!r}]")  # 0.7 is refused

    # ------------------------------------------------------------------ PettingZoo API

    def reset(self, seed: int | None = None, options: dict | None = None):
        """``options={"instance": ...}`` loads an instance of the same shape, as the Gym env's
        reset does; other keys are ignored (PettingZoo's API test passes some)."""
        given = {k: v for k, v in reset_options(options).items() if k == "instance"}
        obs, _ = self.env.reset(seed=seed, options=given or None)
        self.agents = list(self.possible_agents)
        return self._observations(obs), {a: {"slot": 0} for a in self.agents}

    def step(self, actions: dict[str, Any]):
        if not self.agents:
            raise OptionError("step: no episode is running (before reset(), or after the last slot): call reset()")
        if not isinstance(actions, dict):
            raise OptionError(f"actions: must be a dict of agent -> action, got {type(actions).__name__}")
        unknown = sorted(set(actions) - set(self.possible_agents), key=str)
        if unknown:
            raise OptionError(f"actions: unknown agent {unknown[0]!r} (the agents: {', '.join(self.possible_agents)})")
        joint, replaced = self._resolve(actions)
        obs, reward, terminated, truncated, info = self.env.step(self._join(joint))
        rewards = {a: reward - (self.penalty if r else 0.0) for a, r in zip(self.possible_agents, replaced, strict=True)}
        infos = {a: {"slot": info["slot"], "replaced": r, "executed": int(x), "idle_slots": info["idle_slots"]}
                 for a, r, x in zip(self.possible_agents, replaced, joint, strict=True)}
        if "upload_success" in info:  # MODEL.md section 11: each robot's outcome (None: no upload)
            got = info["upload_success"]
            for k, agent in enumerate(self.possible_agents):
                infos[agent]["upload_success"] = got[k] if isinstance(got, list) else got
        observations = self._observations(obs)
        done = dict.fromkeys(self.agents, bool(terminated))
        cut = dict.fromkeys(self.agents, bool(truncated))
        if terminated or truncated:
            self.agents = []
        return observations, rewards, done, cut, infos

    def _observations(self, obs: dict[str, np.ndarray]) -> dict[str, dict[str, np.ndarray]]:
        legal = self._legal() if self.env.t < self.instance.horizon else []
        robots = obs["position"].reshape(-1, 2)
        shared = {k: v for k, v in obs.items() if k != "position"}
        out = {}
        for k, agent in enumerate(self.possible_agents):
            mask = np.zeros(self._n, dtype=np.int8)
            mask[sorted({t[k] for t in legal})] = 1
            out[agent] = {"position": robots[k].copy(), "robots": robots.copy(), **shared, "action_mask": mask}
        return out

    def plan(self) -> Plan | FleetPlan:
        """The episode's plan so far (a FleetPlan for several robots)."""
        return self.env.plan()

    def render(self):
        return self.env.render()

    def close(self) -> None:
        self.env.close()


def parallel_env(instance: Instance, **kwargs) -> VoIParallelEnv:
    """The PettingZoo ParallelEnv of ``instance``: one agent per robot (keyword options as VoIEnv's
    reward, render_mode, penalty, reward_units, observe_sensors)."""
    return VoIParallelEnv(instance, **kwargs)
