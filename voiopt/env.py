"""A Gymnasium environment over the MDP of models/mdp.py (the ``[rl]`` extra).

    import voiopt.env, gymnasium
    env = gymnasium.make("voiopt/VoICollection-v0", instance=voiopt.load("instances/case-study.json"))

Observation: MultiDiscrete [k, l, A_1..A_N, q_1..q_N] (lattice coordinates, ages, distance
indices as in models/mdp.py). Action: Discrete((N + 1) * 5), number = upload * 5 + move with
upload 0 = none, 1 + i = sensor i, move 0..4 = stay, N, S, E, W. ``info["action_mask"]`` marks
the feasible actions (with the field rules of MODEL.md section 9: never onto a blocked point,
and always with a way left to ``end`` within the slots and the ``max_moves`` budget); an
infeasible one is executed as its feasible part (no upload, and its move if feasible, else
stay, or the first move of the way to end) with ``info["feasible"] = False``, so every rollout
is a legal plan. An episode is T slots.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from voiopt.errors import MissingExtraError, OptionError

try:
    import gymnasium as gym
    from gymnasium import spaces
except ImportError as e:  # pragma: no cover - depends on the installed extras
    raise MissingExtraError("gymnasium", "rl") from e

from voiopt import lattice as lattice_mod
from voiopt.instance import Instance
from voiopt.models import mdp as mdp_mod

ENV_ID = "voiopt/VoICollection-v0"
CELL = 24  # pixels per lattice point in rgb_array renders


class VoIEnv(gym.Env):
    """The entity's slot-by-slot decision (upload, move) with the paper's reward."""

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}

    def __init__(self, instance: Instance, reward: str = "voi", render_mode: str | None = None,
                 penalty: float = mdp_mod.IDLE_PENALTY, reward_units: str = "bit/s"):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise OptionError(f"render_mode: must be 'ansi' or 'rgb_array', got {render_mode!r}")
        self.instance = instance
        self.model = mdp_mod.build(instance, reward, penalty, reward_units=reward_units)
        self.lattice = lattice_mod.build(instance)
        self.render_mode = render_mode
        N, lat = instance.n_sensors, self.lattice
        max_age = int(self.model.voi_reward.shape[1] - 1)
        self.observation_space = spaces.MultiDiscrete(
            [lat.nx, lat.ny] + [max_age + 1] * N + [lat.n_points + 1] * N, dtype=np.int64
        )
        self.action_space = spaces.Discrete((N + 1) * 5)
        # global action number -> per-point action number (or -1 if infeasible there)
        self._local = np.full((lat.n_points, (N + 1) * 5), -1, dtype=np.int64)
        for p in range(lat.n_points):
            for k, (u, m) in enumerate(self.model.actions(p)):
                self._local[p, (u + 1) * 5 + m] = k
        self.state = self.model.initial_state()
        self.t = 0

    def _obs(self) -> np.ndarray:
        p, aoi, qidx, *_ = self.state
        k, l = self.lattice.coords[p]
        return np.array([k, l, *aoi, *qidx], dtype=np.int64)

    def action_mask(self) -> np.ndarray:
        """Bool mask over the Discrete actions: feasible in the current state and slot (no
        move off the area or onto a blocked point, and one that leaves a way to ``end`` within
        the slots and moves left, MODEL.md section 9)."""
        local = self._local[self.state[0]]
        mask = local >= 0
        if self.t < self.instance.horizon:
            mask[mask] = self.model.feasible(self.state, self.t)[local[mask]]
        return mask

    def _info(self, feasible: bool = True) -> dict[str, Any]:
        return {"action_mask": self.action_mask(), "slot": self.t, "feasible": feasible}

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.state = self.model.initial_state()
        self.t = 0
        return self._obs(), self._info()

    def step(self, action):
        a = int(action)
        if not 0 <= a < self.action_space.n:
            raise OptionError(f"action: must be in 0..{self.action_space.n - 1}, got {action!r}")
        if self.t >= self.instance.horizon:
            raise RuntimeError("step() after the episode ended: call reset()")
        p = self.state[0]
        mask = self.action_mask()
        feasible = bool(mask[a])
        k = int(self._local[p, a])
        if not feasible:  # no upload, the move if feasible, else the first move of the way to end
            move = a % 5
            if not mask[move]:
                home = self.lattice.walk_home(p, 1)[0]
                move = next(m for m in range(5) if self.lattice.neighbors[p, m] == home)
            k = int(self._local[p, move])
        self.state, reward = self.model.step(self.state, k)
        self.t += 1
        terminated = self.t >= self.instance.horizon
        return self._obs(), float(reward), terminated, False, self._info(feasible)

    def render(self):
        if self.render_mode == "ansi":
            return self._ansi()
        if self.render_mode == "rgb_array":
            return self._rgb()
        return None

    def _ansi(self) -> str:
        lat, p = self.lattice, self.state[0]
        rows = []
        for l in reversed(range(lat.ny)):
            cells = []
            for k in range(lat.nx):
                q = k * lat.ny + l
                near = np.flatnonzero(lat.in_range[:, q])
                cells.append("R" if q == p else (str(near[0] % 10) if len(near) else "."))
            rows.append(" ".join(cells))
        _, aoi, *_ = self.state
        rows.append(f"slot {self.t}/{self.instance.horizon}  AoI {list(aoi)}")
        return "\n".join(rows) + "\n"

    def _rgb(self) -> np.ndarray:
        lat, p = self.lattice, self.state[0]
        img = np.full((lat.ny * CELL, lat.nx * CELL, 3), 255, dtype=np.uint8)
        for q in range(lat.n_points):
            k, l = lat.coords[q]
            y0, x0 = (lat.ny - 1 - l) * CELL, k * CELL
            color = (230, 230, 230)
            if lat.in_range[:, q].any():
                color = (170, 200, 255)
            if q == p:
                color = (220, 40, 40)
            img[y0 + 2: y0 + CELL - 2, x0 + 2: x0 + CELL - 2] = color
        for s in self.instance.sensors:
            x = int(round(s.position[0] / lat.step * CELL + CELL / 2))
            y = int(round((lat.ny - 1 - s.position[1] / lat.step) * CELL + CELL / 2))
            img[max(y - 3, 0): y + 3, max(x - 3, 0): x + 3] = (20, 60, 200)
        return img


if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="voiopt.env:VoIEnv", max_episode_steps=None)
