"""Upload outcomes in the Gymnasium and PettingZoo envs under lossy links (MODEL.md section 11).

On a lossy instance each scheduled upload succeeds with probability p_i(d), drawn from the
env's own generator (``np_random``, seeded by ``reset(seed=...)``), robot by robot in index
order; a failed upload acts as no upload (the slot is used, and no ``f_penalty`` is charged
for it: the robot did schedule a sensor). On an instance that is not lossy nothing is drawn,
so every random stream and every step is exactly as without ``links``. The outcome is in
``info["upload_success"]``: True, False, or None where nothing was uploaded (a list, one entry
per robot, for a fleet); the key is absent on instances that are not lossy.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from voiopt.core.instance import Instance
from voiopt.core.links import is_lossy, success_table
from voiopt.grid import lattice as lattice_mod


class Outcomes:
    """The success probabilities of an env's instance, and the draws of its steps."""

    def __init__(self, instance: Instance) -> None:
        self.table = success_table(instance, lattice_mod.build(instance)) if is_lossy(instance) else None
        self.fleet = bool(instance.fleet)

    def draw(self, rng: np.random.Generator, points, uploads) -> list[bool | None] | None:
        """Each robot's outcome (None where it uploads nothing), or None on a lossless instance."""
        if self.table is None:
            return None
        return [None if u < 0 else bool(rng.random() < self.table[p, u]) for p, u in zip(points, uploads, strict=True)]

    @staticmethod
    def failed(outcome: list[bool | None] | None) -> bool:
        return bool(outcome) and False in outcome

    @staticmethod
    def refunded(reward: float, outcome: list[bool | None] | None, penalty: float) -> float:
        """``reward`` with the f_penalty the model charged for each failed upload (executed as no
        upload) given back; ``reward`` itself, untouched, where nothing failed."""
        failed = sum(ok is False for ok in outcome or ())
        return reward + penalty * failed if failed else reward

    def info(self, outcome: list[bool | None] | None) -> dict[str, Any]:
        if outcome is None:
            return {}
        return {"upload_success": list(outcome) if self.fleet else outcome[0]}
