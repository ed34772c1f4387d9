"""Random field rules (MODEL.md section 9) for generated networks, and the factory-floor preset.

``draw`` adds obstacles, an end point and a move budget to a network; ``factory`` builds the
preset floor: racks of shelving in rows with aisles between them, a dock in a corner where the
shift starts and ends, and sensors on the machines and shelves along the aisles.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math

import numpy as np

from voiopt.core import instance as instance_mod
from voiopt.core.instance import (
    LATTICE_TOL,
    Channel,
    Instance,
    Robot,
    Sensor,
    check_size,
    lattice_shape,
    point_index,
)
from voiopt.errors import OptionError, check_seed
from voiopt.grid import paths
from voiopt.grid.places import show_xy

END_CHOICES = ("start", "random")
MAX_OBSTACLE_POINTS = 10_000  # obstacles are placed one by one with a connectivity check each


def check_options(blocked_fraction, end, max_moves, horizon) -> None:
    """One-line errors for the generator's field options."""
    if isinstance(blocked_fraction, bool) or not isinstance(blocked_fraction, (int, float)) or not (
            0 <= blocked_fraction < 1):
        raise OptionError(f"blocked-fraction: must be a number in [0, 1), got {blocked_fraction!r}")
    if end is not None and not (end in END_CHOICES or _is_point(end)):
        raise OptionError(f"end: must be 'start', 'random' or a point X,Y, got {end!r}")
    if max_moves is not None and (isinstance(max_moves, bool) or not isinstance(max_moves, int) or max_moves < 0):
        raise OptionError(f"max-moves: must be an integer >= 0, got {max_moves!r}")


def _is_point(v) -> bool:
    return (isinstance(v, (tuple, list)) and len(v) == 2
            and all(isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in v))


def parse_end(text: str) -> str | tuple[float, float]:
    """``--end start|random|X,Y`` as the generator's ``end``."""
    if text in END_CHOICES:
        return text
    try:
        x, y = (float(c) for c in text.split(","))
    except ValueError:
        raise OptionError(f"--end: must be start, random or X,Y, got {text!r}") from None
    return (x, y)


def draw(inst: Instance, rng: np.random.Generator, blocked_fraction: float, end, max_moves: int | None) -> Instance:
    """``inst`` with random obstacles, an end point and a budget (draws in that order)."""
    nx, ny = lattice_shape(inst.width, inst.height, inst.step)
    start = point_index(inst.start, inst.step, ny)
    fixed_end = point_index(end, inst.step, ny) if _is_point(end) else None
    blocked = np.zeros(nx * ny, dtype=bool)
    if blocked_fraction:
        if nx * ny > MAX_OBSTACLE_POINTS:
            raise OptionError(f"blocked-fraction: random obstacles need a lattice of at most {MAX_OBSTACLE_POINTS} "
                              f"points, got {nx * ny}")
        keep = {start} | ({fixed_end} if fixed_end is not None else set())
        blocked = _connected_obstacles(nx, ny, round(blocked_fraction * nx * ny), keep, rng)
    end_point = None
    if end == "start":
        end_point = inst.start
    elif end == "random":
        steps = paths.steps(nx, ny, blocked, start)
        reach = np.flatnonzero(steps <= min(inst.horizon - 1, inst.horizon if max_moves is None else max_moves))
        k = int(reach[rng.integers(len(reach))])
        end_point = _point(k, inst.step, ny)
    elif end is not None:
        end_point = (float(end[0]), float(end[1]))
    points = tuple(_point(k, inst.step, ny) for k in np.flatnonzero(blocked))
    return dataclasses.replace(inst, blocked=points, end=end_point, max_moves=max_moves)


def add_robots(inst: Instance, rng: np.random.Generator, robots: int, dock: bool, end=None) -> Instance:
    """``inst`` (one robot) with ``robots`` robots in all (MODEL.md section 10), drawn after
    everything else so that robot 0 is the one-robot network's. Starts are distinct: uniform
    on the free points, or with ``dock`` the free points nearest robot 0's start (fewest
    moves, then index). Every robot has robot 0's budget. ``end`` as the generator took it:
    "start" gives each robot its own start as end; "random" a free point it reaches in time
    and budget, distinct from the others' ends; a point, the free points nearest it. Ends are
    drawn again ("random", up to END_TRIES times) or handed to the robots in another order (a
    point) until the robots can all reach them together (voiopt.grid.joint: in a corridor two robots
    cannot pass), since validation rejects a fleet with no legal joint plan."""
    if isinstance(robots, bool) or not isinstance(robots, int) or robots < 1:
        raise OptionError(f"robots: must be an integer >= 1, got {robots!r}")
    if robots == 1:
        return inst
    nx, ny = lattice_shape(inst.width, inst.height, inst.step)
    blocked = np.zeros(nx * ny, dtype=bool)
    for b in inst.blocked:
        blocked[point_index(b, inst.step, ny)] = True
    free = np.flatnonzero(~blocked)
    if robots > min(len(free), instance_mod.MAX_ROBOTS):
        raise OptionError(f"robots: must be at most {min(len(free), instance_mod.MAX_ROBOTS)} (one free lattice "
                          f"point each), got {robots}")
    first = point_index(inst.start, inst.step, ny)
    for _ in range(END_TRIES if end == "random" else 1):
        if dock:
            starts = _nearest(nx, ny, blocked, first, robots)
        else:
            starts = [first, *rng.choice(free[free != first], robots - 1, replace=False).tolist()]
        ends = starts if end == "start" else [None] * robots if end is None else _together_ends(inst, rng, end, nx,
                                                                                                ny, blocked, starts)
        if ends is not None:
            break
    else:
        raise OptionError(f"end: network {inst.name}: {END_TRIES} draws of starts and ends for robots 1..{robots - 1} "
                          f"gave none that can finish together with robot 0 (from {show_xy(inst.start)} to "
                          f"{show_xy(inst.end)}, the one-robot network's) in {inst.horizon} slots: two robots may not share "
                          f"or swap points, and the free points may leave no room to pass; give fewer robots, fewer "
                          f"obstacles or --end start")
    fleet = tuple(Robot(_point(a, inst.step, ny), None if b is None else _point(b, inst.step, ny), inst.max_moves)
                  for a, b in zip(starts, ends, strict=True))
    return dataclasses.replace(inst, start=fleet[0].start, end=fleet[0].end, fleet=fleet)


END_TRIES = 100  # draws of random ends for robots that must reach them together


def _together_ends(inst: Instance, rng: np.random.Generator, end, nx: int, ny: int, blocked: np.ndarray,
                   starts: list[int]) -> list[int] | None:
    """add_robots' ends by ``end`` that the robots can reach together from ``starts`` (or where
    joint.possible cannot decide): "random", one draw (None if they cannot); a point, the free
    points nearest it in the first order of the robots that works (OptionError if none does)."""
    from voiopt.grid import joint  # numba: only for robots with ends

    budget = inst.horizon - 1 if inst.max_moves is None else min(inst.horizon - 1, inst.max_moves)
    together = functools.partial(joint.possible, nx, ny, tuple(np.flatnonzero(blocked).tolist()), tuple(starts))
    moves = (inst.max_moves,) * len(starts)
    if end == "random":
        ends = [point_index(inst.end, inst.step, ny)]
        for k in starts[1:]:
            reach = [int(q) for q in np.flatnonzero(paths.steps(nx, ny, blocked, k) <= budget) if q not in ends]
            ends.append(reach[int(rng.integers(len(reach)))] if reach else k)
        return ends if together(tuple(ends), moves, inst.horizon) is not False else None
    nearest = _nearest(nx, ny, blocked, point_index(inst.end, inst.step, ny), len(starts))
    for ends in itertools.islice(itertools.permutations(nearest), 120):
        if together(ends, moves, inst.horizon) is not False:
            return list(ends)
    raise OptionError(f"end: network {inst.name}: the {len(starts)} free points nearest {show_xy(inst.end)} cannot be "
                      f"reached by the {len(starts)} robots together in {inst.horizon} slots, in any order (two robots "
                      f"may not share or swap points); give another end, fewer robots or a longer horizon")


def _nearest(nx: int, ny: int, blocked: np.ndarray, origin: int, count: int) -> list[int]:
    """The ``count`` free points nearest ``origin`` in moves (then index), ``origin`` first."""
    steps = paths.steps(nx, ny, blocked, origin)
    order = np.lexsort((np.arange(nx * ny), steps))
    return [int(q) for q in order[:count] if steps[q] < paths.UNREACHABLE]


def _connected_obstacles(nx: int, ny: int, count: int, keep: set[int], rng: np.random.Generator) -> np.ndarray:
    """``count`` blocked points in random order, each skipped if it would cut the free points
    apart (a BFS from a kept point must still reach every free one)."""
    blocked = np.zeros(nx * ny, dtype=bool)
    root = min(keep)
    placed = 0
    for k in rng.permutation(nx * ny).tolist():
        if placed == count:
            break
        if k in keep:
            continue
        blocked[k] = True
        if (paths.steps(nx, ny, blocked, root)[~blocked] >= paths.UNREACHABLE).any():
            blocked[k] = False
            continue
        placed += 1
    return blocked


def _point(k: int, step: float, ny: int) -> tuple[float, float]:
    return (float(k // ny) * step, float(k % ny) * step)


# ------------------------------------------------------------------------------- factory

FACTORY_SIZE = 20.0  # metres: a 21 x 21 lattice with step 1
FACTORY_HORIZON = 100
FACTORY_SENSORS = (10, 30)
FACTORY_RHO = (0.6, 0.99)
FACTORY_MAX_MOVES = 80  # of the 99 slots: the battery allows four moves in five


def factory_blocked(size: int = int(FACTORY_SIZE)) -> list[tuple[int, int]]:
    """The racks: blocks two points wide and six long in two rows, with aisles three points
    wide between them, a cross aisle in the middle and free bands along the walls."""
    out = []
    for x0 in range(3, size - 2, 5):  # rack columns at x0, x0 + 1; aisles of two between
        for y0, y1 in ((3, 8), (12, 17)):  # two rows of racks, a cross aisle at y = 9..11
            out += [(x, y) for x in (x0, x0 + 1) for y in range(y0, y1 + 1) if x <= size - 3]
    return out


def seeded(seed) -> tuple[np.random.Generator, object]:
    """The random stream of a generated network, and the seed its default name shows. A seed is
    an integer >= 0; generate_set gives each of its networks a numpy SeedSequence, named by
    its entropy."""
    if isinstance(seed, np.random.SeedSequence):
        return np.random.default_rng(seed), seed.entropy
    check_seed(seed)
    return np.random.default_rng(seed), seed


def factory(n_sensors: int | None = None, horizon: int = FACTORY_HORIZON, *, seed: int | np.random.SeedSequence = 0,
            max_moves: int | None = FACTORY_MAX_MOVES, rho: tuple[float, float] = FACTORY_RHO,
            channel: Channel | None = None, name: str | None = None, robots: int = 1, links: dict | None = None) -> Instance:
    """The factory-floor preset: a 20 x 20 m floor with racks of shelving (``factory_blocked``),
    the dock at the corner (0, 0) as start and end, ``n_sensors`` (default: uniform in 10..30)
    on machines and shelves, each within d_th of an aisle point, rho ~ U(0.6, 0.99), T = 100 and
    a budget of 80 moves. With ``robots`` K > 1, the K robots start and end at the free points
    nearest the dock (MODEL.md section 10: no two share a point). ``links``: as ``generate``'s."""
    if n_sensors is not None and (isinstance(n_sensors, bool) or not isinstance(n_sensors, int) or n_sensors < 1):
        raise OptionError(f"sensors: must be an integer >= 1, got {n_sensors!r}")
    if isinstance(horizon, bool) or not isinstance(horizon, int) or horizon < 1:
        raise OptionError(f"horizon: must be an integer >= 1, got {horizon!r}")
    check_options(0.0, None, max_moves, horizon)
    check_size(FACTORY_SENSORS[1] if n_sensors is None else n_sensors, horizon, (int(FACTORY_SIZE) + 1) ** 2)
    rng, seed_label = seeded(seed)  # after the checks: nothing drawn that would be refused
    channel = channel or Channel()
    size = int(FACTORY_SIZE)
    blocked = factory_blocked(size)
    free = np.array([(x, y) for x in range(size + 1) for y in range(size + 1) if (x, y) not in set(blocked)], float)
    n = int(rng.integers(FACTORY_SENSORS[0], FACTORY_SENSORS[1] + 1)) if n_sensors is None else n_sensors
    sensors = []
    while len(sensors) < n:
        x, y = rng.uniform(0, FACTORY_SIZE, size=2)
        if np.hypot(free[:, 0] - x, free[:, 1] - y).min() > channel.d_th - LATTICE_TOL:
            continue  # no aisle point within range: the robot could never collect it
        sensors.append(Sensor((round(float(x), 6), round(float(y), 6)), float(rng.uniform(*rho)), 1.0, 1, None))
    if name is None:
        name = f"factory-n{n}-t{horizon}-seed{seed_label}"
    dock = (0.0, 0.0)
    inst = Instance(name, FACTORY_SIZE, FACTORY_SIZE, horizon, dock, tuple(sensors), 1.0, channel,
                    tuple((float(x), float(y)) for x, y in blocked), dock, max_moves)
    inst = add_robots(inst, rng, robots, dock=True, end="start")
    return instance_mod.from_dict(inst.to_dict() | ({} if links is None else {"links": links}))
