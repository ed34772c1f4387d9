"""Instance, Sensor, Channel: the network of MODEL.md section 1, JSON in and out.

Validation is hand-written so that every message names the field path and the offending
value (``sensors[2].rho: must be in (0, 1), got 1.0``); nothing is guessed or clamped.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from voiopt._files import loads_json, read_json, write_json_atomic
from voiopt.errors import InstanceError

LATTICE_TOL = 1e-9  # absolute tolerance for "is a lattice point" and "within d_th"


@dataclass(frozen=True)
class Channel:
    g0_db: float = -50.0
    bandwidth_hz: float = 2e6
    noise_dbm_per_hz: float = -110.0
    d_th: float = 1.0


@dataclass(frozen=True)
class Sensor:
    position: tuple[float, float]
    rho: float
    power_w: float = 1.0
    initial_aoi: int = 1
    initial_distance: float | None = None  # None means channel.d_th


@dataclass(frozen=True)
class Instance:
    name: str
    width: float
    height: float
    horizon: int
    start: tuple[float, float]
    sensors: tuple[Sensor, ...]
    step: float = 1.0
    channel: Channel = field(default_factory=Channel)

    @property
    def n_sensors(self) -> int:
        return len(self.sensors)

    def initial_distance(self, i: int) -> float:
        q = self.sensors[i].initial_distance
        return self.channel.d_th if q is None else q

    def to_dict(self) -> dict[str, Any]:
        c = self.channel
        return {
            "name": self.name,
            "area": {"width": self.width, "height": self.height},
            "step": self.step,
            "horizon": self.horizon,
            "start": list(self.start),
            "channel": {
                "g0_db": c.g0_db,
                "bandwidth_hz": c.bandwidth_hz,
                "noise_dbm_per_hz": c.noise_dbm_per_hz,
                "d_th": c.d_th,
            },
            "sensors": [
                {
                    "position": list(s.position),
                    "rho": s.rho,
                    "power_w": s.power_w,
                    "initial_aoi": s.initial_aoi,
                    "initial_distance": self.initial_distance(i),
                }
                for i, s in enumerate(self.sensors)
            ],
        }

    def replace(self, **changes: Any) -> Instance:
        """A copy with some fields changed, validated again."""
        d = self.to_dict()
        for key, value in changes.items():
            d[key] = value
        return from_dict(d)


# ----------------------------------------------------------------------------- validation


class _Checker:
    """Collects every violated rule, so one run reports them all (the first is raised)."""

    def __init__(self) -> None:
        self.errors: list[str] = []

    def fail(self, path: str, message: str) -> None:
        """Record a violated rule (returns None, the value of a field that failed)."""
        self.errors.append(f"{path}: {message}")

    def obj(self, value: Any, path: str, allowed: set[str], required: set[str]) -> dict | None:
        if not isinstance(value, dict):
            self.fail(path or "instance", f"must be an object, got {_show(value)}")
            return None
        for key in value:
            if key not in allowed:
                self.fail(_join(path, key), f"unknown field (allowed: {', '.join(sorted(allowed))})")
        for key in sorted(required):
            if key not in value:
                self.fail(_join(path, key), "is required")
        return value

    def number(self, d: dict, key: str, path: str, default: float | None = None, *, positive: bool = False,
               nonnegative: bool = False, open01: bool = False) -> float | None:
        if key not in d:
            return default
        p, v = _join(path, key), d[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            return self.fail(p, f"must be a number, got {_show(v)}")
        if isinstance(v, int) and abs(v) > 2**1000:  # float() would overflow
            return self.fail(p, f"must be finite, got {_show(v)}")
        v = float(v)
        rules = (
            (math.isfinite(v), "must be finite"),
            (not positive or v > 0, "must be > 0"),
            (not nonnegative or v >= 0, "must be >= 0"),
            (not open01 or 0 < v < 1, "must be in (0, 1)"),
        )
        for ok, rule in rules:
            if not ok:
                return self.fail(p, f"{rule}, got {_show(v)}")
        return v

    def integer(self, d: dict, key: str, path: str, default: int | None, minimum: int) -> int | None:
        v = d.get(key, default)
        if key not in d:
            return v
        if isinstance(v, float) and math.isfinite(v) and v.is_integer():
            v = int(v)
        if isinstance(v, bool) or not isinstance(v, int):
            return self.fail(_join(path, key), f"must be an integer, got {_show(v)}")
        if v < minimum:
            return self.fail(_join(path, key), f"must be an integer >= {minimum}, got {_show(v)}")
        return v

    def point(self, d: dict, key: str, path: str) -> tuple[float, float] | None:
        p = _join(path, key)
        v = d.get(key)
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            self.fail(p, f"must be a pair [x, y], got {_show(v)}")
            return None
        out = []
        for j, c in enumerate(v):
            if isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c):
                self.fail(f"{p}[{j}]", f"must be a finite number, got {_show(c)}")
                return None
            out.append(float(c))
        return (out[0], out[1])


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _show(v: Any) -> str:
    if isinstance(v, float):
        if math.isnan(v):
            return "NaN"
        if math.isinf(v):
            return "Infinity" if v > 0 else "-Infinity"
        return repr(v)
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10**60:
        return f"an integer of {len(str(abs(v) // 10**60)) + 60} digits" if v.bit_length() < 14000 else "a huge integer"
    try:
        text = json.dumps(v) if isinstance(v, (str, list, dict, bool, type(None))) else repr(v)
    except (ValueError, RecursionError):
        text = f"a {type(v).__name__}"
    return text if len(text) <= 60 else text[:57] + "..."


def on_lattice(x: float, step: float) -> bool:
    k = round(x / step)
    return abs(k * step - x) <= LATTICE_TOL


def from_dict(d: Any, source: str = "") -> Instance:
    """Validate a decoded instance JSON object; raise InstanceError naming the first bad field."""
    ck = _Checker()
    top = {"name", "area", "step", "horizon", "start", "channel", "sensors"}
    d = ck.obj(d, "", top, {"area", "horizon", "start", "sensors"})
    if d is None:
        _raise(ck, source)
    name = d.get("name", Path(source).stem if source else "instance")
    if not isinstance(name, str) or not name:
        ck.fail("name", f"must be a non-empty string, got {_show(name)}")

    width = height = None
    area = ck.obj(d.get("area", {}), "area", {"width", "height"}, {"width", "height"})
    if area is not None:
        width = ck.number(area, "width", "area", positive=True)
        height = ck.number(area, "height", "area", positive=True)
    step = ck.number(d, "step", "", 1.0, positive=True)
    horizon = ck.integer(d, "horizon", "", None, 1)

    channel = Channel()
    if "channel" in d:
        ch = ck.obj(d["channel"], "channel", {"g0_db", "bandwidth_hz", "noise_dbm_per_hz", "d_th"}, set())
        if ch is not None:
            g0 = ck.number(ch, "g0_db", "channel", -50.0)
            bw = ck.number(ch, "bandwidth_hz", "channel", 2e6, positive=True)
            n0 = ck.number(ch, "noise_dbm_per_hz", "channel", -110.0)
            dth = ck.number(ch, "d_th", "channel", 1.0, positive=True)
            if None not in (g0, bw, n0, dth):
                channel = Channel(g0, bw, n0, dth)

    start = None
    if "start" in d:
        start = ck.point(d, "start", "")
        if start is not None and None not in (width, height, step):
            x, y = start
            if not (on_lattice(x, step) and on_lattice(y, step)):
                ck.fail("start", f"must be a lattice point (multiples of step {step:g}), got {_show(list(start))}")
            elif not (-LATTICE_TOL <= x <= width + LATTICE_TOL and -LATTICE_TOL <= y <= height + LATTICE_TOL):
                ck.fail("start", f"must lie in the area [0, {width:g}] x [0, {height:g}], got {_show(list(start))}")
            else:
                start = (round(x / step) * step, round(y / step) * step)

    sensors: list[Sensor] = []
    raw = d.get("sensors")
    if "sensors" in d and (not isinstance(raw, list) or not raw):
        ck.fail("sensors", f"must be a non-empty list, got {_show(raw)}")
        raw = []
    for i, s in enumerate(raw or []):
        path = f"sensors[{i}]"
        s = ck.obj(s, path, {"position", "rho", "power_w", "initial_aoi", "initial_distance"}, {"position", "rho"})
        if s is None:
            continue
        pos = ck.point(s, "position", path) if "position" in s else None
        if pos is not None and None not in (width, height):
            if not (0 <= pos[0] <= width and 0 <= pos[1] <= height):
                ck.fail(f"{path}.position", f"must lie in the area [0, {width:g}] x [0, {height:g}], got {_show(list(pos))}")
        rho = ck.number(s, "rho", path, None, open01=True) if "rho" in s else None
        power = ck.number(s, "power_w", path, 1.0, positive=True)
        aoi = ck.integer(s, "initial_aoi", path, 1, 1)
        q0 = ck.number(s, "initial_distance", path, None, nonnegative=True)
        if None not in (pos, rho, power, aoi):
            sensors.append(Sensor(pos, rho, power, aoi, q0))

    if ck.errors:
        _raise(ck, source)
    return Instance(name, width, height, horizon, start, tuple(sensors), step, channel)


def _raise(ck: _Checker, source: str) -> None:
    where = f"{source}: " if source else ""
    more = f" (and {len(ck.errors) - 1} more)" if len(ck.errors) > 1 else ""
    err = InstanceError(f"{where}{ck.errors[0]}{more}")
    err.all_errors = list(ck.errors)
    raise err


def load(path: str | os.PathLike) -> Instance:
    """Load and validate an instance JSON file."""
    return from_dict(read_json(path), source=str(path))


def loads(text: str) -> Instance:
    return from_dict(loads_json(text))


def save(instance: Instance, path: str | os.PathLike) -> None:
    write_json_atomic(path, instance.to_dict())
