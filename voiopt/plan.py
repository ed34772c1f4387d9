"""Plan: positions and schedule of MODEL.md section 3, JSON in and out, losslessly."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

from voiopt import lattice
from voiopt._files import read_json
from voiopt.errors import PlanError
from voiopt.instance import Instance


def _num(v: float) -> float | int:
    """Integral floats as ints, so lattice points read [1, 0] rather than [1.0, 0.0]."""
    return int(v) if float(v).is_integer() and abs(v) < 2**53 else float(v)


@dataclass(frozen=True)
class Plan:
    positions: tuple[tuple[float, float], ...]
    schedule: tuple[int | None, ...]

    @classmethod
    def from_dict(cls, d: Any) -> Plan:
        """A plan object, or a whole result JSON whose ``plan`` is used."""
        if isinstance(d, dict) and "plan" in d and "positions" not in d:
            d = d["plan"]
            where = "plan."
        else:
            where = ""
        if not isinstance(d, dict):
            raise PlanError(f"plan: must be an object with positions and schedule, got {type(d).__name__}")
        unknown = set(d) - {"positions", "schedule"}
        if unknown:
            raise PlanError(f"{where}{sorted(unknown)[0]}: unknown field (allowed: positions, schedule)")
        for key in ("positions", "schedule"):
            if not isinstance(d.get(key), list):
                raise PlanError(f"{where}{key}: must be a list, got {d.get(key)!r}")
        positions = []
        for t, p in enumerate(d["positions"]):
            ok = isinstance(p, list) and len(p) == 2 and all(
                isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in p
            )
            if not ok:
                raise PlanError(f"{where}positions[{t}]: must be a pair [x, y] of finite numbers, got {p!r}")
            positions.append((float(p[0]), float(p[1])))
        schedule = []
        for t, u in enumerate(d["schedule"]):
            if isinstance(u, float) and u.is_integer():
                u = int(u)
            if u is not None and (isinstance(u, bool) or not isinstance(u, int)):
                raise PlanError(f"{where}schedule[{t}]: must be a sensor index or null, got {u!r}")
            schedule.append(u)
        return cls(tuple(positions), tuple(schedule))

    def to_dict(self) -> dict[str, Any]:
        return {
            "positions": [[_num(x), _num(y)] for x, y in self.positions],
            "schedule": list(self.schedule),
        }

    @classmethod
    def from_indices(cls, instance: Instance, idx, sched) -> Plan:
        """A plan from lattice point indices and a schedule with -1 for none."""
        pts = lattice.build(instance).points
        return cls(
            tuple((float(pts[p, 0]), float(pts[p, 1])) for p in idx),
            tuple(None if u < 0 else int(u) for u in sched),
        )


def load_plan(path: str | os.PathLike) -> Plan:
    return Plan.from_dict(read_json(path, error=PlanError))
