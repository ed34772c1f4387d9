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
  pairs, so the lattice (73 bytes a point, 8 more with an ``end``, 9 more a point and sensor, ``lattice.build``)
  needs at most 100 MB;
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

import dataclasses
import math
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from voiopt.errors import InstanceError, InstanceWarning, OptionError
from voiopt.grid.places import (  # noqa: F401  (the lattice's geometry and caps are also instance.py's names)
    LATTICE_TOL,
    MAX_LATTICE_POINTS,
    MAX_ROBOTS,
    check_blocked,
    check_robots,
    check_route,
    check_together,
    lattice_point,
    lattice_shape,
    on_lattice,
    point_index,
)
from voiopt.runtime.checker import Checker as _Checker
from voiopt.runtime.checker import show
from voiopt.runtime.files import loads_json, read_json, write_json_atomic

MAX_HORIZON = 10**6
MAX_AGE = 2 * 10**6  # initial_aoi + horizon: the largest age A_i(t)
MAX_SENSORS = 10**4
MAX_SENSOR_POINTS = 2 * 10**6  # sensors x lattice points
MAX_DB = 3000.0  # |g0_db|, |noise_dbm_per_hz|
MIN_LINEAR, MAX_LINEAR = 1e-300, 1e300  # B * N0, P * g0 and B * N0 * d^2 [W]; the SNR at any distance
MAX_BANDWIDTH_HZ = 1e300
MAX_NAME = 200


def check_size(n_sensors: int, horizon: int, n_points: float, max_initial_aoi: int = 1) -> None:
    """The sizes a generator is asked for, refused before anything is drawn when the instance
    it would draw breaks a cap of this module (the generator's option names)."""
    if n_sensors > MAX_SENSORS:
        raise OptionError(f"sensors: must be at most {MAX_SENSORS} (the cap on sensors), got {n_sensors}")
    if horizon > MAX_HORIZON:
        raise OptionError(f"horizon: must be at most {MAX_HORIZON} (the cap on slots), got {horizon}")
    if max_initial_aoi + horizon > MAX_AGE:
        raise OptionError(f"initial-aoi: its largest, {max_initial_aoi}, plus the horizon {horizon} must be at most "
                          f"{MAX_AGE} (the cap on ages)")
    if n_sensors * n_points > MAX_SENSOR_POINTS:
        raise OptionError(f"sensors: {n_sensors} sensors on {n_points:.0f} lattice points make more than "
                          f"{MAX_SENSOR_POINTS} sensor-lattice point pairs (the cap of an instance)")


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
    success: float | None = None  # MODEL.md section 11: this sensor's success probability (only with links)


@dataclass(frozen=True)
class Links:
    """Lossy links of MODEL.md section 11: ``bernoulli`` with ``success``, or ``rayleigh`` with
    ``snr_threshold_db`` (the other field None); voiopt.core.links gives the probabilities."""

    model: str
    success: float | None = None
    snr_threshold_db: float | None = None


@dataclass(frozen=True)
class Robot:
    """One collector of MODEL.md section 10: its start, and its own section-9 end and budget."""

    start: tuple[float, float]
    end: tuple[float, float] | None = None
    max_moves: int | None = None


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
    blocked: tuple[tuple[float, float], ...] = ()  # MODEL.md section 9: points never stood on
    end: tuple[float, float] | None = None  # the point of the last slot, positions[T-1]
    max_moves: int | None = None  # at most this many slots with a change of position
    # MODEL.md section 10: two or more robots (then start, end and max_moves above are robot 0's,
    # and only ``robot(k)`` may be planned alone); () for one robot, whichever form its file used
    fleet: tuple[Robot, ...] = ()
    links: Links | None = None  # MODEL.md section 11: uploads may fail; None, every upload succeeds

    @property
    def n_sensors(self) -> int:
        return len(self.sensors)

    @property
    def n_robots(self) -> int:
        return max(1, len(self.fleet))

    @property
    def robots(self) -> tuple[Robot, ...]:
        """Every robot, one entry for a one-robot instance."""
        return self.fleet or (Robot(self.start, self.end, self.max_moves),)

    def robot(self, k: int) -> Instance:
        """The one-robot instance of robot k alone: the network, with robot k's start, end and
        budget (its lattice, rules and bounds are those of section 9)."""
        if not self.fleet:
            if k != 0:
                raise IndexError(f"robot {k}: the instance has one robot")
            return self
        r = self.fleet[k]
        return dataclasses.replace(self, start=r.start, end=r.end, max_moves=r.max_moves, fleet=())

    @property
    def has_field_rules(self) -> bool:
        """Any of the optional rules of MODEL.md section 9 is given (by any robot)."""
        return bool(self.blocked) or any(r.end is not None or r.max_moves is not None for r in self.robots)

    def initial_distance(self, i: int) -> float:
        q = self.sensors[i].initial_distance
        return self.channel.d_th if q is None else q

    def to_dict(self) -> dict[str, Any]:
        c = self.channel
        d = {
            "name": self.name,
            "area": {"width": self.width, "height": self.height},
            "step": self.step,
            "horizon": self.horizon,
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
                    **({} if s.success is None else {"success": s.success}),
                }
                for i, s in enumerate(self.sensors)
            ],
        }
        if self.links is not None:  # section 11's field only when given
            d["links"] = {k: v for k, v in dataclasses.asdict(self.links).items() if v is not None}
        if self.blocked:  # section 9's fields only when given: the paper's files stay as they were
            d["blocked"] = [list(b) for b in self.blocked]
        if self.fleet:
            d["robots"] = [_robot_dict(r) for r in self.fleet]
        else:
            d.update(_robot_dict(self.robots[0]))
        return {k: d[k] for k in _ORDER if k in d}

    def replace(self, **changes: Any) -> Instance:
        """A copy with some fields changed, validated again."""
        d = self.to_dict()
        for key, value in changes.items():
            d[key] = value
        return from_dict(d)


_ORDER = ("name", "area", "step", "horizon", "start", "robots", "channel", "sensors", "blocked", "end", "max_moves",
          "links")


def _robot_dict(r: Robot) -> dict[str, Any]:
    """A robot's fields as JSON, section 9's only when given."""
    d: dict[str, Any] = {"start": list(r.start)}
    if r.end is not None:
        d["end"] = list(r.end)
    if r.max_moves is not None:
        d["max_moves"] = r.max_moves
    return d


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


_SENSOR_FIELDS = frozenset({"position", "rho", "power_w", "initial_aoi", "initial_distance", "success"})
_SENSOR_REQUIRED = ("position", "rho")
LINK_MODELS = {"bernoulli": "success", "rayleigh": "snr_threshold_db"}  # each model's own field


def _probability(ck: _Checker, d: dict, key: str, path: str) -> float | None:
    """A success probability of MODEL.md section 11: a finite number in (0, 1]."""
    p = ck.number(d, key, path)
    if p is not None and not 0 < p <= 1:
        return ck.fail(f"{path}.{key}", f"must be a probability in (0, 1], got {show(d[key])}")
    return p


def _check_links(ck: _Checker, raw: Any) -> Links | None:
    """The ``links`` object of MODEL.md section 11 (a field of the other model is unknown)."""
    d = ck.obj(raw, "links", {"model", *LINK_MODELS.values()}, {"model"})
    if d is None or "model" not in d:
        return None
    model = d["model"]
    if not isinstance(model, str) or model not in LINK_MODELS:
        return ck.fail("links.model", f"must be one of {', '.join(map(repr, LINK_MODELS))}, got {show(model)}")
    own = LINK_MODELS[model]
    for other in set(LINK_MODELS.values()) - {own}:
        if other in d:
            ck.fail(f"links.{other}", f"unknown field for model {model!r} (allowed: model, {own})")
    if own not in d:
        return ck.fail(f"links.{own}", f"is required for model {model!r}")
    value = _probability(ck, d, own, "links") if model == "bernoulli" else ck.number(d, own, "links")
    if value is None:
        return None
    return Links(model, success=value) if model == "bernoulli" else Links(model, snr_threshold_db=value)


def from_dict(d: Any, source: str = "") -> Instance:
    """Validate a decoded instance JSON object; raise InstanceError naming the first bad field."""
    ck = _Checker()
    if isinstance(d, dict) and "sensors" not in d and ({"positions", "schedule", "plan"} & d.keys()):
        what = "a result JSON" if "plan" in d else "a plan"
        raise InstanceError(f"{source + ': ' if source else ''}{what}, not an instance (an instance has area, horizon, "
                            "sensors and start)")
    top = {"name", "area", "step", "horizon", "start", "robots", "channel", "sensors", "blocked", "end", "max_moves",
           "links"}
    d = ck.obj(d, "", top, {"area", "horizon", "sensors"})
    if d is None:
        _raise(ck, source)
    if ("start" in d) == ("robots" in d):
        ck.fail("start", "is required (or robots, for several robots)" if "start" not in d else
                "must not be given with robots (each robot has its own start)")
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

    area_ok = n_points is not None
    blocked = check_blocked(ck, d["blocked"], width, height, step, area_ok, n_points) if "blocked" in d else ()
    robots = check_robots(ck, d, width, height, step, area_ok)
    links = _check_links(ck, d["links"]) if "links" in d else None

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
        success = _probability(ck, s, "success", path) if "success" in s else None
        if "success" in s and "links" not in d:
            ck.fail(f"{path}.success", f"is only allowed with links (MODEL.md section 11), got {show(s['success'])}")
        if power is not None and bn0 is not None:
            d_max = math.sqrt(min(MAX_LINEAR, MAX_LINEAR * power * g0) / bn0)
            far.append((i, d_max, "initial_distance" in s))
            if q0 is not None and q0 > d_max:
                ck.fail(f"{path}.initial_distance", f"must be <= {d_max:.3g} m, where the SNR P g0 / (B N0 d^2) of "
                                                    f"this sensor falls to {MIN_LINEAR:g}, got {show(s['initial_distance'])}")
                q0 = None
        if None not in (pos, rho, power, aoi) and ("success" not in s or success is not None):
            sensors.append(Sensor(pos, rho, power, aoi, q0, success))

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

    if not ck.errors:
        for path, (start, end, max_moves) in robots:
            if blocked or end is not None:
                check_route(ck, width, height, step, horizon, start, end, blocked, max_moves, path)
    if not ck.errors:
        check_together(ck, width, height, step, horizon, blocked, robots)
    if ck.errors:
        _raise(ck, source)
    _warn_duplicates(sensors, source)
    fleet = tuple(Robot(*r) for _, r in robots)
    first = fleet[0]
    fleet = fleet if len(fleet) > 1 else ()
    return Instance(name, width, height, horizon, first.start, tuple(sensors), step, channel, blocked, first.end,
                    first.max_moves, fleet, links)


def _warn_duplicates(sensors: list[Sensor], source: str) -> None:
    """A sensor with the position and parameters of an earlier one is legal (two devices on one
    machine) but more often a copy-paste: warn once, naming both."""
    seen: dict[tuple, int] = {}
    for i, s in enumerate(sensors):
        j = seen.setdefault(dataclasses.astuple(s), i)
        if j != i:
            where = f"{source}: " if source else ""
            warnings.warn(f"{where}sensors[{i}]: same position and parameters as sensors[{j}] (both are kept; "
                          "is it a copy?)", InstanceWarning, stacklevel=3)
            return


def _raise(ck: _Checker, source: str) -> None:
    where = f"{source}: " if source else ""
    others = len(ck.errors) - 1 + ck.dropped
    more = f" (and {others} more)" if others else ""
    err = InstanceError(f"{where}{ck.errors[0]}{more}")
    err.all_errors = list(ck.errors) + ([f"... and {ck.dropped} more"] if ck.dropped else [])
    raise err


def load(path: str | os.PathLike) -> Instance:
    """Load and validate an instance JSON file."""
    if not isinstance(path, (str, os.PathLike)):
        raise OptionError(f"path: must be the path of an instance file, got {show(path)}")
    return from_dict(read_json(path), source=str(path))


def as_instance(value: Any, field: str) -> Instance:
    """An Instance, or the path of an instance file loaded; anything else is an OptionError
    naming ``field`` (the Python API's arguments, which the command line never passes)."""
    if isinstance(value, Instance):
        return value
    if isinstance(value, (str, os.PathLike)):
        return load(value)
    raise OptionError(f"{field}: must be an Instance or the path of an instance file, got {show(value)}")


def loads(text: str) -> Instance:
    return from_dict(loads_json(text))


def save(instance: Instance, path: str | os.PathLike) -> None:
    write_json_atomic(path, instance.to_dict())
