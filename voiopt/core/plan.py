"""Plan: positions and schedule of MODEL.md section 3, JSON in and out, losslessly."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from itertools import chain
from typing import Any

import numpy as np

from voiopt.core.instance import MAX_HORIZON, MAX_ROBOTS, MAX_SENSORS, Instance, show
from voiopt.errors import PlanError
from voiopt.grid import lattice
from voiopt.runtime.files import read_json, reading


def _num(v: float) -> float | int:
    """Integral floats as ints, so lattice points read [1, 0] rather than [1.0, 0.0]."""
    return int(v) if float(v).is_integer() and abs(v) < 2**53 else float(v)


def _finite(c: Any) -> float | None:
    """A coordinate as a float, or None if it is not a finite number (huge ints included)."""
    if isinstance(c, bool) or not isinstance(c, (int, float)):
        return None
    try:
        f = float(c)
    except OverflowError:
        return None
    return f if math.isfinite(f) else None


def _fast(positions: list, schedule: list) -> tuple[tuple, tuple] | None:
    """positions and schedule as ``Plan._one`` reads them, at C speed, for the usual file:
    pairs of ints or finite floats, and ints (of at most MAX_SENSORS) or nulls; None for anything
    else, which the slot-by-slot reading then names (T = 10^6: 4.5 s slot by slot)."""
    if set(map(type, positions)) - {list} or set(map(len, positions)) - {2}:
        return None
    if set(map(type, chain.from_iterable(positions))) - {int, float} or set(map(type, schedule)) - {int, type(None)}:
        return None
    try:
        xy = np.array(positions, dtype=float).reshape(len(positions), 2)
    except OverflowError:  # an int beyond a float
        return None
    uploads = [u for u in schedule if u is not None]
    if not np.isfinite(xy).all() or (uploads and not -MAX_SENSORS <= min(uploads) <= max(uploads) < MAX_SENSORS):
        return None
    return tuple(map(tuple, xy.tolist())), tuple(schedule)


def _key(k: Any) -> str:
    return k if isinstance(k, str) and k.isidentifier() and len(k) <= 40 else show(k, 40)


@dataclass(frozen=True)
class Plan:
    """One robot's plan: p(t) and u(t) for t = 0..T-1."""

    positions: tuple[tuple[float, float], ...]
    schedule: tuple[int | None, ...]

    @property
    def robots(self) -> tuple[Plan, ...]:
        """Each robot's plan: this one (a FleetPlan has one per robot)."""
        return (self,)

    @classmethod
    def from_dict(cls, d: Any) -> Plan | FleetPlan:
        """A plan object, or a whole result JSON whose ``plan`` is used: the flat form of
        MODEL.md section 3 or the ``robots`` form of section 10 (a FleetPlan; a one-entry list
        is that robot's Plan, the same plan). Every message names the field and shows the
        value briefly (``show``), however large or deep it is."""
        if isinstance(d, dict) and "plan" in d and "positions" not in d and "robots" not in d:
            d = d["plan"]
            where = "plan."
        else:
            where = ""
        if isinstance(d, dict) and "robots" in d:
            return FleetPlan.from_dict(d, where)
        return cls._one(d, where)

    @classmethod
    def _one(cls, d: Any, where: str) -> Plan:
        if not isinstance(d, dict):
            raise PlanError(f"{where.rstrip('.') or 'plan'}: must be an object with positions and schedule, got {show(d)}")
        unknown = [k for k in d if k not in ("positions", "schedule")]
        if unknown:
            raise PlanError(f"{where}{_key(unknown[0])}: unknown field (allowed: positions, schedule)")
        for key in ("positions", "schedule"):
            if key not in d:
                raise PlanError(f"{where}{key}: is required")
            v = d[key]
            if not isinstance(v, list):
                raise PlanError(f"{where}{key}: must be a list, got {show(v)}")
            if len(v) > MAX_HORIZON:
                raise PlanError(f"{where}{key}: must have at most {MAX_HORIZON} entries (the cap on the horizon), "
                                f"got {len(v)}")
        fast = _fast(d["positions"], d["schedule"])
        if fast is not None:
            return cls(*fast)
        positions = []
        for t, p in enumerate(d["positions"]):
            xy = [_finite(c) for c in p] if isinstance(p, list) and len(p) == 2 else None
            if xy is None or None in xy:
                raise PlanError(f"{where}positions[{t}]: must be a pair [x, y] of finite numbers, got {show(p)}")
            positions.append((xy[0], xy[1]))
        schedule = []
        for t, v in enumerate(d["schedule"]):
            u = int(v) if isinstance(v, float) and math.isfinite(v) and v.is_integer() else v
            if u is not None and (isinstance(u, bool) or not isinstance(u, int)):
                raise PlanError(f"{where}schedule[{t}]: must be a sensor index or null, got {show(v)}")
            if u is not None and not -MAX_SENSORS <= u < MAX_SENSORS:
                raise PlanError(f"{where}schedule[{t}]: must be a sensor index or null, got {show(v)} "
                                f"(an instance has at most {MAX_SENSORS} sensors)")
            schedule.append(None if u is None else int(u))
        return cls(tuple(positions), tuple(schedule))

    def to_dict(self) -> dict[str, Any]:
        try:  # each distinct point converted once (T = 10^6: 1.7 s as a loop over the slots)
            pair = {xy: (_num(x), _num(y)) for xy in set(self.positions) for x, y in (xy,)}
            positions = list(map(list, map(pair.__getitem__, self.positions)))
        except (TypeError, ValueError):  # positions that are not hashable pairs (a plan built in Python)
            positions = [[_num(x), _num(y)] for x, y in self.positions]
        return {"positions": positions, "schedule": list(self.schedule)}

    @classmethod
    def from_indices(cls, instance: Instance, idx, sched) -> Plan | FleetPlan:
        """A plan from lattice point indices and a schedule with -1 for none: (T,) arrays for
        one robot, (K, T) arrays for a fleet (a FleetPlan)."""
        pts = lattice.build(instance).points
        if np.ndim(idx) == 2:
            return FleetPlan(tuple(cls.from_indices(instance, i, u) for i, u in zip(idx, sched, strict=True)))
        idx, sched = np.asarray(idx), np.asarray(sched)
        if (idx.size and idx.dtype.kind not in "iu") or (sched.size and sched.dtype.kind not in "iu"):
            raise TypeError(f"point indices and schedule must be integers, got {idx.dtype} and {sched.dtype}")
        xy = [(float(x), float(y)) for x, y in pts.tolist()]  # each point's pair once (T = 10^6: 1.2 s before)
        return cls(tuple(map(xy.__getitem__, idx.astype(np.int64).tolist())),
                   tuple(None if u < 0 else u for u in sched.tolist()))


@dataclass(frozen=True)
class FleetPlan:
    """A plan for K >= 2 robots (MODEL.md section 10): one Plan per robot, in file order."""

    robots: tuple[Plan, ...]

    @classmethod
    def from_dict(cls, d: dict, where: str = "") -> Plan | FleetPlan:
        unknown = [k for k in d if k != "robots"]
        if unknown:
            raise PlanError(f"{where}{_key(unknown[0])}: unknown field beside robots (a fleet plan is "
                            "{\"robots\": [{positions, schedule}, ...]})")
        raw = d["robots"]
        if not isinstance(raw, list) or not raw or len(raw) > MAX_ROBOTS:
            raise PlanError(f"{where}robots: must be a list of 1 to {MAX_ROBOTS} plans {{positions, schedule}}, "
                            f"got {show(raw)}")
        plans = tuple(Plan._one(r, f"{where}robots[{k}].") for k, r in enumerate(raw))
        return plans[0] if len(plans) == 1 else cls(plans)

    def to_dict(self) -> dict[str, Any]:
        return {"robots": [p.to_dict() for p in self.robots]}


def made_for(d: Any) -> str | None:
    """The instance a decoded result JSON names (None: not a result, or no name)."""
    name = d.get("instance") if isinstance(d, dict) and "plan" in d else None
    return name if isinstance(name, str) else None


def load_plan(path: str | os.PathLike, instance_name: str | None = None) -> Plan | FleetPlan:
    """The plan of a plan file or a result JSON; every error names the file. With
    ``instance_name``, a result made for another instance (by its ``instance`` field) is
    refused: its plan would be judged against the wrong network."""
    return plan_of(read_json(path, error=PlanError), path, instance_name)


def plan_of(d: Any, path: str | os.PathLike, instance_name: str | None = None) -> Plan | FleetPlan:
    """``load_plan`` of a file's JSON ``d`` already read (``path`` names it in errors)."""
    if isinstance(d, dict) and "sensors" in d:
        raise PlanError(f"{path}: an instance, not a plan ({{positions, schedule}}) or a result JSON")
    if isinstance(d, dict) and d.get("format") == "voiopt-policy":
        raise PlanError(f"{path}: a policy, not a plan: a policy acts on what it observes (voiopt show draws it; "
                        "voiopt.Policy.load acts on it; voiopt solve reports its value)")
    if isinstance(d, dict) and "objective" in d and d.get("plan") is None and d.get("evaluation") is not None:
        saved = d["solver"].get("policy_file") if isinstance(d.get("solver"), dict) else None
        raise PlanError(f"{path}: a policy's result, which holds no plan" + (f" (its policy is {saved})" if saved else "")
                        + ": voiopt show draws it; its value is the result's own")
    if isinstance(d, dict) and "objective" in d and "plan" not in d and "positions" not in d and "robots" not in d:
        raise PlanError(f"{path}: a result without a plan field")
    other = made_for(d)
    if instance_name is not None and other is not None and other != instance_name:
        raise PlanError(f"{path}: a result for instance {show(other)}, not for {show(instance_name)}")
    with reading(path, PlanError):
        return Plan.from_dict(d)
