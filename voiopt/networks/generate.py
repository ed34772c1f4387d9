"""Random networks with the paper's distributions (MODEL.md section 8), and the case study."""

from __future__ import annotations

import json
import os
from importlib import resources
from pathlib import Path

import numpy as np

from voiopt.core import instance as instance_mod
from voiopt.core.instance import Channel, Instance, Sensor, show
from voiopt.core.plan import Plan
from voiopt.errors import OptionError, PlanError, check_seed
from voiopt.networks import fields
from voiopt.runtime import files


def generate(
    n_sensors: int = 4,
    horizon: int = 30,
    *,
    width: float = 5.0,
    height: float = 5.0,
    step: float = 1.0,
    rho: tuple[float, float] = (0.0, 1.0),
    power_w: float = 1.0,
    initial_aoi: tuple[int, int] = (1, 1),
    channel: Channel | None = None,
    seed: int | np.random.SeedSequence = 0,
    name: str | None = None,
    blocked_fraction: float = 0.0,
    end: str | tuple[float, float] | None = None,
    max_moves: int | None = None,
    robots: int = 1,
    dock: bool = False,
    links: dict | None = None,
) -> Instance:
    """One random network: sensors uniform in the area, start uniform on the lattice,
    rho ~ U(rho[0], rho[1]) (redrawn in the rare case it hits 0 or 1), initial AoI uniform
    on the integers initial_aoi[0]..initial_aoi[1]. Same seed, same network.

    The field rules of MODEL.md section 9, drawn after everything else (so the paper's
    networks do not change): ``blocked_fraction`` of the lattice points blocked at random,
    never the start or end and never cutting the free points apart; ``end`` "start", "random"
    (a free point the entity can reach in time and budget) or a point (x, y); ``max_moves``.
    ``robots`` K > 1 (MODEL.md section 10) adds robots 1..K-1 after that (fields.add_robots):
    distinct starts, uniform or with ``dock`` around robot 0's start, and ends by ``end``.
    ``links`` (MODEL.md section 11, an instance's ``links`` object) is added last, drawing nothing."""
    _check(n_sensors, horizon, width, height, step, rho, power_w, initial_aoi, channel)
    rng, seed_label = fields.seeded(seed)
    fields.check_options(blocked_fraction, end, max_moves, horizon)
    channel = channel or Channel()
    nx = int(np.floor(width / step + instance_mod.LATTICE_TOL)) + 1
    ny = int(np.floor(height / step + instance_mod.LATTICE_TOL)) + 1
    sensors = []
    for _ in range(n_sensors):
        x, y = rng.uniform(0, width), rng.uniform(0, height)
        r = rng.uniform(rho[0], rho[1])
        while not 0 < r < 1:
            r = rng.uniform(rho[0], rho[1])
        a = int(rng.integers(initial_aoi[0], initial_aoi[1] + 1))
        sensors.append(Sensor((round(float(x), 6), round(float(y), 6)), float(r), float(power_w), a, None))
    start = (float(rng.integers(nx)) * step, float(rng.integers(ny)) * step)
    if name is None:
        name = f"n{n_sensors}-t{horizon}-seed{seed_label}"
    inst = Instance(name, float(width), float(height), int(horizon), start, tuple(sensors), float(step), channel)
    if blocked_fraction or end is not None or max_moves is not None:
        inst = fields.draw(inst, rng, blocked_fraction, end, max_moves)
    if robots != 1 or dock:
        inst = fields.add_robots(inst, rng, robots, dock, end)
    return instance_mod.from_dict(inst.to_dict() | ({} if links is None else {"links": links}))  # validated like any file


PRESETS = ("factory",)
MAX_COUNT = 100_000  # networks in one set: they are drawn in memory before any is written


def generate_set(count: int, seed: int = 0, preset: str | None = None, **kwargs) -> list[Instance]:
    """``count`` independent networks; network k depends only on (seed, k). ``preset``
    "factory" draws factory floors (fields.factory, which takes n_sensors, horizon and
    max_moves) instead of the paper's networks."""
    if isinstance(count, bool) or not isinstance(count, int | np.integer) or not 1 <= count <= MAX_COUNT:
        raise OptionError(f"count: must be an integer from 1 to {MAX_COUNT}, got {count!r}")
    check_seed(seed)
    if preset is not None and preset not in PRESETS:
        raise OptionError(f"preset: must be one of {', '.join(PRESETS)}, got {preset!r}")
    base = kwargs.pop("name", None)
    children = np.random.SeedSequence(seed).spawn(count)
    out = []
    for k, child in enumerate(children):
        n = kwargs.get("n_sensors", 4)
        t = kwargs.get("horizon", 30)
        if preset == "factory":
            name = f"{base or f'factory-seed{seed}'}-{k:03d}"
            out.append(fields.factory(seed=child, name=name, **kwargs))
            continue
        name = f"{base or f'n{n}-t{t}-seed{seed}'}-{k:03d}"
        out.append(generate(seed=child, name=name, **kwargs))
    return out


def write_set(instances: list[Instance], out_dir: str | os.PathLike, *, overwrite: bool = True) -> list[Path]:
    """Write each instance to ``out_dir/<name>.json``. With ``overwrite=False`` (the command
    line's default), nothing is written if a file there already holds another instance: a
    name depends on N, T and the seed alone, so two different sets (another rho, say) would
    otherwise replace each other's files silently. Rewriting the same instance is fine."""
    out = Path(out_dir)
    paths = [out / f"{files.safe_name(inst.name)}.json" for inst in instances]
    if not overwrite:
        for inst, p in zip(instances, paths, strict=True):
            _refuse_another(p, inst)
    for inst, p in zip(instances, paths, strict=True):
        instance_mod.save(inst, p)
    return paths


def write_one(instance: Instance, path: str | os.PathLike, *, overwrite: bool = True) -> Path:
    """Write one instance to the file ``path``; with ``overwrite=False``, refuse (writing
    nothing) if the file holds another instance."""
    p = Path(path)
    files.check_output_file(p, "--out")
    if not overwrite:
        _refuse_another(p, instance)
    instance_mod.save(instance, p)
    return p


def _refuse_another(path: Path, inst: Instance) -> None:
    """OptionError if the file exists and holds another instance (write_set's and write_one's refusal)."""
    if path.exists() and not _holds(path, inst):
        raise OptionError(f"--out: {path} already holds another instance; choose another --out, or --overwrite to "
                          "replace it")


def _holds(path: Path, inst: Instance) -> bool:
    """The file is this instance, as save() writes it."""
    try:
        return json.loads(path.read_text(encoding="utf-8")) == json.loads(json.dumps(inst.to_dict()))
    except (OSError, ValueError):
        return False


def _check(n_sensors, horizon, width, height, step, rho, power_w, initial_aoi, channel) -> None:
    if not (isinstance(n_sensors, int) and n_sensors >= 1):
        raise OptionError(f"sensors: must be an integer >= 1, got {n_sensors!r}")
    if not (isinstance(horizon, int) and horizon >= 1):
        raise OptionError(f"horizon: must be an integer >= 1, got {horizon!r}")
    for key, v in (("width", width), ("height", height), ("step", step), ("power", power_w)):
        if not _number(v):
            raise OptionError(f"{key}: must be a number > 0, got {show(v)}")
        if not (np.isfinite(v) and v > 0):
            raise OptionError(f"{key}: must be > 0, got {v!r}")
    nx, ny = instance_mod.lattice_shape(width, height, step)
    if not nx * ny <= instance_mod.MAX_LATTICE_POINTS:  # before drawing a start among them
        raise OptionError(f"width, height, step: a {width:g} x {height:g} area with step {step:g} has more than "
                          f"{instance_mod.MAX_LATTICE_POINTS} lattice points (the cap of instance.py)")
    if _pair(initial_aoi) and all(isinstance(a, int) for a in initial_aoi):
        instance_mod.check_size(n_sensors, horizon, nx * ny, initial_aoi[1])  # before drawing what would be refused
    else:
        instance_mod.check_size(n_sensors, horizon, nx * ny)
    if not (_pair(rho) and 0 <= rho[0] <= rho[1] <= 1) or rho[0] == rho[1] in (0, 1):
        raise OptionError(f"rho: must be a range 0 <= lo <= hi <= 1 with points inside (0, 1), got {show(rho)}")
    if not (_pair(initial_aoi) and all(isinstance(a, int) for a in initial_aoi) and 1 <= initial_aoi[0] <= initial_aoi[1]):
        raise OptionError(f"initial-aoi: must be a range 1 <= lo <= hi of integers, got {show(initial_aoi)}")
    if channel is not None and not isinstance(channel, Channel):
        raise OptionError(f"channel: must be a voiopt.Channel or None, got {show(channel)}")


def _number(v) -> bool:
    """A real number (a Python or numpy one, a Fraction, a 0-d array), not a bool or a string."""
    if isinstance(v, (bool, np.bool_, str, bytes)) or np.ndim(v) != 0:
        return False
    try:
        float(v)
    except (TypeError, ValueError, OverflowError):
        return False
    return True


def _pair(v) -> bool:
    """A pair (lo, hi) of numbers: a tuple, a list or an array of two."""
    return not isinstance(v, (str, bytes, dict)) and hasattr(v, "__len__") and len(v) == 2 and all(_number(x) for x in v)


# The paper's Fig. 3/4 case study: N = 3, rho = [0.7, 0.6, 0.5], A(0) = [2, 4, 4], P = 1 W,
# T = 10. The paper does not give positions; ours (voiopt/data/case-study.json) are
# illustrative, as is the hand-made legal plan beside it (optimal for mean-min-voi only).
DATA = resources.files("voiopt") / "data"


def case_study() -> Instance:
    """The shipped case study (the same file as instances/case-study.json)."""
    return instance_mod.from_dict(files.loads_json(DATA.joinpath("case-study.json").read_text("utf-8")), "case-study")


def case_study_plan() -> Plan:
    """The hand-made example plan of the case study."""
    return Plan.from_dict(files.loads_json(DATA.joinpath("case-study.plan.json").read_text("utf-8"), PlanError))
