"""Instance, Sensor, Channel: the network of MODEL.md section 1, JSON in and out.

Validation is hand-written so that every message names the field path and the offending
value (``sensors[2].rho: must be in (0, 1), got 1.0``); nothing is guessed or clamped.

Besides the rules of MODEL.md, validation rejects what no method can hold, and says the
limit in the message (the caps below). They are far above the paper's networks (a 5 x 5
area with step 1 has 36 lattice points, T = 10..100, N up to a few dozen) and 20 x 20
factory floors, and they keep every derived number finite:

- ``horizon`` <= 10**6 slots; ``initial_aoi + horizon`` <= 2 * 10**6, the largest age A_i(t):
  ages are counts of slots, capped like the horizon (Q-learning's reward table has a row
  per age, so an initial AoI of 10**9 would ask it for gigabytes per sensor);
- at most 10**6 lattice points, counted from width / step and height / step without building
  anything (and without overflow); at most 10**4 sensors; at most 2 * 10**6 sensor-point
  pairs, so the lattice (72 bytes a point and 9 more a point and sensor, ``lattice.build``)
  needs at most 90 MB;
- ``g0_db`` and ``noise_dbm_per_hz`` in [-3000, 3000] dB, so g0 = 10^(g0_db/10) and
  N0 = 10^(noise/10)/1000 are finite and > 0; B * N0 and P_i * g0 in [1e-300, 1e300] W;
  B <= 1e300 Hz (VoI is at most 53 B bit/s, as -log2(1 - rho) <= 53 for a float rho < 1,
  so its sums over the horizon stay finite); every distance the model can meet (the area's
  diagonal, each initial_distance) keeps B N0 d^2 <= 1e300 and the SNR P g0 / (B N0 d^2) of
  every sensor >= 1e-300, so the upload quality P g0 / (B N0 d^2 + P g0) and its log are
  finite and > 0 (the MILP takes logs of them);
- ``name`` (it names output files) at most 200 printable characters, no / or \\.
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from voiopt._files import loads_json, read_json, write_json_atomic
from voiopt.errors import InstanceError

LATTICE_TOL = 1e-9  # absolute tolerance for "is a lattice point" and "within d_th"

MAX_HORIZON = 10**6
MAX_AGE = 2 * 10**6  # initial_aoi + horizon: the largest age A_i(t)
MAX_LATTICE_POINTS = 10**6
MAX_SENSORS = 10**4
MAX_SENSOR_POINTS = 2 * 10**6  # sensors x lattice points
MAX_DB = 3000.0  # |g0_db|, |noise_dbm_per_hz|
MIN_LINEAR, MAX_LINEAR = 1e-300, 1e300  # B * N0, P * g0 and B * N0 * d^2 [W]; the SNR at any distance
MAX_BANDWIDTH_HZ = 1e300
MAX_NAME = 200
MAX_ERRORS = 20  # violations kept in all_errors; the rest are counted


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
    """Collects every violated rule, so one run reports them all (the first is raised).
    At most MAX_ERRORS messages are kept; the rest are only counted."""

    def __init__(self) -> None:
        self.errors: list[str] = []
        self.dropped = 0

    def fail(self, path: str, message: str) -> None:
        """Record a violated rule (returns None, the value of a field that failed)."""
        if len(self.errors) < MAX_ERRORS:
            self.errors.append(f"{path}: {message}")
        else:
            self.dropped += 1

    def obj(self, value: Any, path: str, allowed: set[str] | frozenset[str], required: Any) -> dict | None:
        if not isinstance(value, dict):
            self.fail(path or "instance", f"must be an object, got {show(value)}")
            return None
        for key in value:
            if key not in allowed:
                self.fail(_join(path, key), f"unknown field (allowed: {', '.join(sorted(allowed))})")
        for key in sorted(required):
            if key not in value:
                self.fail(_join(path, key), "is required")
        return value

    def number(self, d: dict, key: str, path: str, default: float | None = None, *, positive: bool = False,
               nonnegative: bool = False, open01: bool = False, within: tuple[float, float, str] | None = None,
               at_most: tuple[float, str] | None = None) -> float | None:
        if key not in d:
            return default
        v = d[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            return self.fail(_join(path, key), f"must be a number, got {show(v)}")
        f = _to_float(v)
        if not math.isfinite(f):
            rule = "must be finite"
        elif positive and not f > 0:
            rule = "must be > 0"
        elif nonnegative and not f >= 0:
            rule = "must be >= 0"
        elif open01 and not 0 < f < 1:
            rule = "must be in (0, 1)"
        elif within is not None and not within[0] <= f <= within[1]:
            rule = f"must be in [{within[0]:g}, {within[1]:g}]{within[2]}"
        elif at_most is not None and not f <= at_most[0]:
            rule = f"must be <= {at_most[0]:g}{at_most[1]}"
        else:
            return f
        return self.fail(_join(path, key), f"{rule}, got {show(v)}")

    def integer(self, d: dict, key: str, path: str, default: int | None, minimum: int,
                maximum: tuple[int, str] | None = None) -> int | None:
        v = d.get(key, default)
        if key not in d:
            return v
        n = int(v) if isinstance(v, float) and math.isfinite(v) and v.is_integer() else v
        if isinstance(n, bool) or not isinstance(n, int):
            return self.fail(_join(path, key), f"must be an integer, got {show(v)}")
        if n < minimum:
            return self.fail(_join(path, key), f"must be an integer >= {minimum}, got {show(v)}")
        if maximum is not None and n > maximum[0]:
            return self.fail(_join(path, key), f"must be an integer <= {maximum[0]}{maximum[1]}, got {show(v)}")
        return int(n)

    def point(self, d: dict, key: str, path: str) -> tuple[float, float] | None:
        v = d.get(key)
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            self.fail(_join(path, key), f"must be a pair [x, y], got {show(v)}")
            return None
        x, y = v
        for j, c in enumerate(v):
            if isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(_to_float(c)):
                self.fail(f"{_join(path, key)}[{j}]", f"must be a finite number, got {show(c)}")
                return None
        return (float(x), float(y))


def _to_float(v: int | float) -> float:
    """float(v), or +-inf for an integer beyond the float range (float() would raise)."""
    try:
        return float(v)
    except OverflowError:
        return math.inf if v > 0 else -math.inf


_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def _join(path: str, key: Any) -> str:
    """``path.key``; a key that is not a plain name (a hostile file's "a\\nb") is quoted, so a
    message stays one short line."""
    if not (isinstance(key, str) and _IDENTIFIER.fullmatch(key) and len(key) <= 40):
        key = show(key, 40)
    return f"{path}.{key}" if path else key


def show(v: Any, limit: int = 60) -> str:
    """A value as it appears in a message: JSON-like, at most ``limit`` characters, cheap for
    huge or deeply nested values (it stops rendering once the text is long enough)."""
    parts, size = [], 0
    for token in _tokens(v, limit):
        parts.append(token)
        size += len(token)
        if size > limit:
            break
    text = "".join(parts)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _show_int(v: int) -> str:
    sign = "a negative" if v < 0 else "an"
    digits = getattr(v, "digits", None)  # _files.HugeInt: a literal of over 1000 digits
    if digits is not None:
        return f"{sign} integer of {digits} digits"
    if abs(v) < 10**60:
        return str(v)
    if v.bit_length() < 13000:  # str() refuses more than 4300 digits
        return f"{sign} integer of {len(str(abs(v)))} digits"
    return f"{sign} integer of about {int(v.bit_length() * math.log10(2)) + 1} digits"


def _tokens(v: Any, limit: int):
    if v is None:
        yield "null"
    elif isinstance(v, bool):
        yield "true" if v else "false"
    elif isinstance(v, int):
        yield _show_int(v)
    elif isinstance(v, float):
        yield "NaN" if math.isnan(v) else ("Infinity" if v > 0 else "-Infinity") if math.isinf(v) else repr(float(v))
    elif isinstance(v, str):
        yield json.dumps(v[: limit + 1])
    elif isinstance(v, (list, tuple, dict)):
        items = v.items() if isinstance(v, dict) else enumerate(v)
        yield "{" if isinstance(v, dict) else "["
        for n, (k, x) in enumerate(items):
            if n:
                yield ", "
            if isinstance(v, dict):
                yield from _tokens(k, limit)
                yield ": "
            yield from _tokens(x, limit)
        yield "}" if isinstance(v, dict) else "]"
    else:
        yield repr(v)[: limit + 1]


def on_lattice(x: float, step: float) -> bool:
    q = x / step
    if not math.isfinite(q):
        return False
    k = round(q)
    return abs(k * step - x) <= LATTICE_TOL


def lattice_shape(width: float, height: float, step: float) -> tuple[float, float]:
    """(nx, ny) of MODEL.md section 2: floor(width / step) + 1 by floor(height / step) + 1.
    Exact ints when the lattice is within the cap; otherwise floats, possibly inf, computed
    without building or overflowing anything."""
    out = []
    for r in (width / step, height / step):
        out.append(math.floor(r + LATTICE_TOL) + 1 if r <= MAX_LATTICE_POINTS else r + 1)
    return out[0], out[1]


def _count(x: float) -> str:
    if x <= 10**15:
        return str(int(x))
    return f"about {x:.3g}" if math.isfinite(x) else "more than 1e+308"


def _check_lattice(ck: _Checker, width: float, height: float, step: float) -> int | None:
    """The number of lattice points, or None (and a failure) when it is over the cap."""
    nx, ny = lattice_shape(width, height, step)
    n = nx * ny
    if n <= MAX_LATTICE_POINTS:
        return int(n)
    if step < 1.0:  # smaller than the default: the step makes it large
        path, value = "step", step
    elif nx > MAX_LATTICE_POINTS or ny <= MAX_LATTICE_POINTS and width >= height:
        path, value = "area.width", width
    else:
        path, value = "area.height", height
    ck.fail(path, f"must leave at most {MAX_LATTICE_POINTS} lattice points, but a {width:g} x {height:g} area "
                  f"with step {step:g} has {_count(n)} ({_count(nx)} x {_count(ny)}), got {show(value)}")
    return None


def _check_name(ck: _Checker, name: Any) -> None:
    if not isinstance(name, str) or not name:
        ck.fail("name", f"must be a non-empty string, got {show(name)}")
    elif len(name) > MAX_NAME or name in (".", "..") or any(c in "/\\" or not c.isprintable() for c in name):
        ck.fail("name", f"must be at most {MAX_NAME} printable characters without / or \\ "
                        f"(it names output files), got {show(name)}")


def _check_channel(ck: _Checker, ch: dict) -> Channel | None:
    note = " dB, so that g0 = 10^(g0_db/10) is finite and > 0"
    g0 = ck.number(ch, "g0_db", "channel", -50.0, within=(-MAX_DB, MAX_DB, note))
    bw = ck.number(ch, "bandwidth_hz", "channel", 2e6, positive=True,
                   at_most=(MAX_BANDWIDTH_HZ, " Hz, so that VoI (up to 53 B bit/s) and its sums stay finite"))
    note = " dBm/Hz, so that N0 = 10^(noise_dbm_per_hz/10)/1000 W/Hz is finite and > 0"
    n0 = ck.number(ch, "noise_dbm_per_hz", "channel", -110.0, within=(-MAX_DB, MAX_DB, note))
    dth = ck.number(ch, "d_th", "channel", 1.0, positive=True)
    if bw is not None and n0 is not None:
        noise = 10.0 ** (n0 / 10.0) / 1000.0
        if not MIN_LINEAR <= bw * noise <= MAX_LINEAR:
            key = "bandwidth_hz" if "bandwidth_hz" in ch else "noise_dbm_per_hz"
            ck.fail(f"channel.{key}", f"bandwidth_hz * N0 must be in [{MIN_LINEAR:g}, {MAX_LINEAR:g}] W, but B = {bw:g} Hz "
                                      f"and N0 = {noise:.3g} W/Hz give {bw * noise:.3g}; got {show(ch[key])}")
            return None
    if None in (g0, bw, n0, dth):
        return None
    return Channel(g0, bw, n0, dth)


_SENSOR_FIELDS = frozenset({"position", "rho", "power_w", "initial_aoi", "initial_distance"})
_SENSOR_REQUIRED = ("position", "rho")


def from_dict(d: Any, source: str = "") -> Instance:
    """Validate a decoded instance JSON object; raise InstanceError naming the first bad field."""
    ck = _Checker()
    top = {"name", "area", "step", "horizon", "start", "channel", "sensors"}
    d = ck.obj(d, "", top, {"area", "horizon", "start", "sensors"})
    if d is None:
        _raise(ck, source)
    name = d.get("name", Path(source).stem if source else "instance")
    if "name" in d:
        _check_name(ck, name)

    width = height = None
    area = ck.obj(d.get("area", {}), "area", {"width", "height"}, {"width", "height"})
    if area is not None:
        width = ck.number(area, "width", "area", positive=True)
        height = ck.number(area, "height", "area", positive=True)
    step = ck.number(d, "step", "", 1.0, positive=True)
    n_points = None if None in (width, height, step) else _check_lattice(ck, width, height, step)
    horizon = ck.integer(d, "horizon", "", None, 1, (MAX_HORIZON, " (the cap on slots)"))

    channel = Channel()
    if "channel" in d:
        ch = ck.obj(d["channel"], "channel", {"g0_db", "bandwidth_hz", "noise_dbm_per_hz", "d_th"}, set())
        channel = None if ch is None else _check_channel(ck, ch)

    start = None
    if "start" in d:
        start = ck.point(d, "start", "")
        if start is not None and n_points is not None:
            x, y = start
            if not (-LATTICE_TOL <= x <= width + LATTICE_TOL and -LATTICE_TOL <= y <= height + LATTICE_TOL):
                ck.fail("start", f"must lie in the area [0, {width:g}] x [0, {height:g}], got {show(list(start))}")
            elif not (on_lattice(x, step) and on_lattice(y, step)):
                ck.fail("start", f"must be a lattice point (multiples of step {step:g}), got {show(list(start))}")
            else:
                start = (round(x / step) * step, round(y / step) * step)

    sensors: list[Sensor] = []
    raw = d.get("sensors")
    if "sensors" in d and (not isinstance(raw, list) or not raw):
        ck.fail("sensors", f"must be a non-empty list, got {show(raw)}")
        raw = []
    elif isinstance(raw, list) and len(raw) > MAX_SENSORS:
        ck.fail("sensors", f"must hold at most {MAX_SENSORS} sensors, got {len(raw)}")
        raw = []
    max_aoi = MAX_AGE - (horizon or 1)
    aoi_note = f" so that initial_aoi + horizon <= {MAX_AGE}, the cap on ages" + (f" (horizon {horizon})" if horizon else "")
    g0 = None if channel is None else 10.0 ** (channel.g0_db / 10.0)
    bn0 = None if channel is None else channel.bandwidth_hz * 10.0 ** (channel.noise_dbm_per_hz / 10.0) / 1000.0
    far: list[tuple[int, float, bool]] = []  # (sensor, largest distance its SNR allows, has initial_distance)
    for i, s in enumerate(raw or []):
        path = f"sensors[{i}]"
        s = ck.obj(s, path, _SENSOR_FIELDS, _SENSOR_REQUIRED)
        if s is None:
            continue
        pos = ck.point(s, "position", path) if "position" in s else None
        if pos is not None and None not in (width, height):
            if not (0 <= pos[0] <= width and 0 <= pos[1] <= height):
                ck.fail(f"{path}.position", f"must lie in the area [0, {width:g}] x [0, {height:g}], got {show(list(pos))}")
        rho = ck.number(s, "rho", path, None, open01=True) if "rho" in s else None
        power = ck.number(s, "power_w", path, 1.0, positive=True)
        if power is not None and g0 is not None and not MIN_LINEAR <= power * g0 <= MAX_LINEAR:
            ck.fail(f"{path}.power_w", f"power_w * g0 must be in [{MIN_LINEAR:g}, {MAX_LINEAR:g}] W "
                                       f"(g0 = {g0:.3g}), got {show(s.get('power_w', power))} giving {power * g0:.3g}")
            power = None
        aoi = ck.integer(s, "initial_aoi", path, 1, 1, (max_aoi, aoi_note))
        q0 = ck.number(s, "initial_distance", path, None, nonnegative=True)
        if power is not None and bn0 is not None:
            d_max = math.sqrt(min(MAX_LINEAR, MAX_LINEAR * power * g0) / bn0)
            far.append((i, d_max, "initial_distance" in s))
            if q0 is not None and q0 > d_max:
                ck.fail(f"{path}.initial_distance", f"must be <= {d_max:.3g} m, where the SNR P g0 / (B N0 d^2) of "
                                                    f"this sensor falls to {MIN_LINEAR:g}, got {show(s['initial_distance'])}")
                q0 = None
        if None not in (pos, rho, power, aoi):
            sensors.append(Sensor(pos, rho, power, aoi, q0))

    if n_points is not None and far:
        diagonal = math.hypot(width, height)
        i, d_max, _ = min(far, key=lambda f: f[1])
        if diagonal > d_max:
            ck.fail("area", f"must have a diagonal <= {d_max:.3g} m, where the SNR P g0 / (B N0 d^2) of sensor {i} "
                            f"falls to {MIN_LINEAR:g}, got {width:g} x {height:g} (diagonal {diagonal:.3g})")
    defaulted = [f for f in far if not f[2]]  # their initial_distance is d_th
    if channel is not None and defaulted and channel.d_th > min(f[1] for f in defaulted):
        i, d_max, _ = min(defaulted, key=lambda f: f[1])
        ck.fail("channel.d_th", f"must be <= {d_max:.3g} m, where the SNR P g0 / (B N0 d^2) of sensor {i} falls to "
                                f"{MIN_LINEAR:g} (its initial_distance defaults to d_th), got {show(channel.d_th)}")
    if n_points is not None and raw and len(raw) * n_points > MAX_SENSOR_POINTS:
        ck.fail("sensors", f"must make at most {MAX_SENSOR_POINTS} sensor-lattice point pairs (the lattice's distance "
                           f"tables), but {len(raw)} sensors on {n_points} lattice points make {len(raw) * n_points}")

    if ck.errors:
        _raise(ck, source)
    return Instance(name, width, height, horizon, start, tuple(sensors), step, channel)


def _raise(ck: _Checker, source: str) -> None:
    where = f"{source}: " if source else ""
    others = len(ck.errors) - 1 + ck.dropped
    more = f" (and {others} more)" if others else ""
    err = InstanceError(f"{where}{ck.errors[0]}{more}")
    err.all_errors = list(ck.errors) + ([f"... and {ck.dropped} more"] if ck.dropped else [])
    raise err


def load(path: str | os.PathLike) -> Instance:
    """Load and validate an instance JSON file."""
    return from_dict(read_json(path), source=str(path))


def loads(text: str) -> Instance:
    return from_dict(loads_json(text))


def save(instance: Instance, path: str | os.PathLike) -> None:
    write_json_atomic(path, instance.to_dict())
