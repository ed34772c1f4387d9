"""An independent brute-force oracle for the voiopt model, written from MODEL.md alone.

Pure Python (math, itertools, collections): no numpy and no voiopt imports, so that a bug
shared by voiopt's simulator and its own brute force cannot hide here too.

Public API
----------
- ``OracleError``                       every rejection (instance or plan), with a reason.
- ``check_instance(d) -> None``         MODEL.md sections 1, 2, 9 and 10.
- ``simulate(d, plan) -> dict``         the four metrics of section 5 of a legal plan.
- ``legal_plans(d)``                    generator of every legal plan, in a fixed order.
- ``count_legal_plans(d) -> int``       their number, by dynamic programming (no enumeration).
- ``brute_force(d, objective, max_plans=200_000) -> (value, plan)``
- ``random_legal_plan(d, rng) -> plan`` a uniformly drawn step-by-step random legal walk.

Conventions (decisions where MODEL.md leaves room; see the report in the commit message):
- Plan positions are coordinates in metres, lattice points (k*step, l*step); a coordinate is
  a lattice coordinate when it is within 1e-9 of k*step.  Internally points are (k, l).
- Distances use the canonical point (k*step, l*step); in range means d <= d_th + 1e-9.
- Plans produced here are in the flat form for an instance given by ``start`` and in the
  ``robots`` form for an instance given by ``robots``; ``simulate`` accepts both forms for one
  robot.
"""

from __future__ import annotations

import itertools
import math
from collections import deque

__all__ = [
    "OracleError",
    "OBJECTIVES",
    "check_instance",
    "simulate",
    "legal_plans",
    "count_legal_plans",
    "brute_force",
    "random_legal_plan",
]

TOL = 1e-9

OBJECTIVES = {  # name -> True when maximised
    "min-voi": True,
    "mean-min-voi": True,
    "max-aoi": False,
    "mean-max-aoi": False,
}

_TOP_KEYS = {
    "name",
    "area",
    "step",
    "horizon",
    "start",
    "channel",
    "sensors",
    "blocked",
    "end",
    "max_moves",
    "robots",
}
_AREA_KEYS = {"width", "height"}
_CHANNEL_KEYS = {"g0_db", "bandwidth_hz", "noise_dbm_per_hz", "d_th"}
_SENSOR_KEYS = {"position", "rho", "power_w", "initial_aoi", "initial_distance"}
_ROBOT_KEYS = {"start", "end", "max_moves"}

# Move order used everywhere (enumeration order, so ties keep the first in this order):
# stay, N (+y), S (-y), E (+x), W (-x).
_MOVES = ((0, 0), (0, 1), (0, -1), (1, 0), (-1, 0))


class OracleError(ValueError):
    """An instance or a plan that breaks the model contract; str(e) is the reason."""


# ----------------------------------------------------------------------------------------
# Instance parsing and validation
# ----------------------------------------------------------------------------------------


class _Robot:
    def __init__(self, start, end, max_moves):
        self.start = start  # (k, l)
        self.end = end  # (k, l) or None
        self.max_moves = max_moves  # int or None (no budget)


class _Sensor:
    def __init__(self, x, y, rho, power, a0, q0):
        self.x, self.y, self.rho, self.power, self.a0, self.q0 = x, y, rho, power, a0, q0


class _Inst:
    """The parsed instance. Points are integer lattice indices (k, l)."""

    def free(self, p):
        k, l = p
        return 0 <= k <= self.kmax and 0 <= l <= self.lmax and p not in self.blocked

    def coords(self, p):
        return (p[0] * self.step, p[1] * self.step)

    def distance(self, p, i):
        s = self.sensors[i]
        x, y = self.coords(p)
        return math.hypot(x - s.x, y - s.y)

    def in_range(self, p, i):
        return self.distance(p, i) <= self.d_th + TOL


def _fail(msg):
    raise OracleError(msg)


def _is_real(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _is_int(v):
    return isinstance(v, int) and not isinstance(v, bool)


def _real(obj, key, path, default=None, positive=False, nonneg=False):
    if key not in obj:
        if default is None:
            _fail(f"{path}.{key}: missing")
        return float(default)
    v = obj[key]
    if not _is_real(v):
        _fail(f"{path}.{key}: {v!r} is not a finite number")
    if positive and not v > 0:
        _fail(f"{path}.{key}: {v!r} must be > 0")
    if nonneg and not v >= 0:
        _fail(f"{path}.{key}: {v!r} must be >= 0")
    return float(v)


def _keys(obj, allowed, path):
    if not isinstance(obj, dict):
        _fail(f"{path}: {obj!r} is not an object")
    unknown = sorted(set(obj) - allowed)
    if unknown:
        _fail(f"{path}: unknown field(s) {unknown}")


def _lattice_point(inst, v, path):
    """(k, l) of a lattice point given in metres, or OracleError (not checked: blocked)."""
    if not (isinstance(v, (list, tuple)) and len(v) == 2 and all(_is_real(c) for c in v)):
        _fail(f"{path}: {v!r} is not a point [x, y]")
    idx = []
    for c in v:
        k = round(c / inst.step)
        if abs(c - k * inst.step) > TOL:
            _fail(f"{path}: {list(v)!r} is not a lattice point (step {inst.step})")
        idx.append(int(k))
    k, l = idx
    if not (0 <= k <= inst.kmax and 0 <= l <= inst.lmax):
        _fail(f"{path}: {list(v)!r} is outside the area")
    return (k, l)


def _max_moves(v, path):
    if not _is_int(v) or v < 0:
        _fail(f"{path}: {v!r} must be an integer >= 0")
    return v


def _parse(d) -> _Inst:
    _keys(d, _TOP_KEYS, "instance")
    inst = _Inst()
    if "name" in d and not isinstance(d["name"], str):
        _fail(f"name: {d['name']!r} is not a string")
    if "area" not in d:
        _fail("area: missing")
    _keys(d["area"], _AREA_KEYS, "area")
    inst.width = _real(d["area"], "width", "area", positive=True)
    inst.height = _real(d["area"], "height", "area", positive=True)
    inst.step = _real(d, "step", "instance", default=1.0, positive=True)
    # lattice: k*step <= width (with a 1e-9 tolerance on the float ratio)
    inst.kmax = int(math.floor(inst.width / inst.step + TOL))
    inst.lmax = int(math.floor(inst.height / inst.step + TOL))
    if "horizon" not in d:
        _fail("horizon: missing")
    T = d["horizon"]
    if not _is_int(T) or T < 1:
        _fail(f"horizon: {T!r} must be an integer >= 1")
    inst.T = T

    ch = d.get("channel", {})
    _keys(ch, _CHANNEL_KEYS, "channel")
    g0_db = _real(ch, "g0_db", "channel", default=-50.0)
    inst.B = _real(ch, "bandwidth_hz", "channel", default=2e6, positive=True)
    n0_dbm = _real(ch, "noise_dbm_per_hz", "channel", default=-110.0)
    inst.d_th = _real(ch, "d_th", "channel", default=1.0, positive=True)
    inst.g0 = 10.0 ** (g0_db / 10.0)
    inst.N0 = 10.0 ** (n0_dbm / 10.0) / 1000.0

    if "sensors" not in d:
        _fail("sensors: missing")
    sensors = d["sensors"]
    if not isinstance(sensors, list) or len(sensors) < 1:
        _fail(f"sensors: {sensors!r} must be a non-empty list")
    inst.sensors = []
    for i, s in enumerate(sensors):
        path = f"sensors[{i}]"
        _keys(s, _SENSOR_KEYS, path)
        if "position" not in s:
            _fail(f"{path}.position: missing")
        pos = s["position"]
        if not (isinstance(pos, (list, tuple)) and len(pos) == 2 and all(_is_real(c) for c in pos)):
            _fail(f"{path}.position: {pos!r} is not a point [x, y]")
        x, y = float(pos[0]), float(pos[1])
        if not (0 <= x <= inst.width and 0 <= y <= inst.height):
            _fail(f"{path}.position: {list(pos)!r} is outside the area")
        if "rho" not in s:
            _fail(f"{path}.rho: missing")
        rho = _real(s, "rho", path)
        if not 0 < rho < 1:
            _fail(f"{path}.rho: {rho!r} must be in (0, 1)")
        power = _real(s, "power_w", path, default=1.0, positive=True)
        a0 = s.get("initial_aoi", 1)
        if not _is_int(a0) or a0 < 1:
            _fail(f"{path}.initial_aoi: {a0!r} must be an integer >= 1")
        q0 = _real(s, "initial_distance", path, default=inst.d_th, nonneg=True)
        inst.sensors.append(_Sensor(x, y, rho, power, a0, q0))

    blocked = d.get("blocked", [])
    if not isinstance(blocked, list):
        _fail(f"blocked: {blocked!r} is not a list")
    bset = set()
    for j, b in enumerate(blocked):
        p = _lattice_point(inst, b, f"blocked[{j}]")
        if p in bset:
            _fail(f"blocked[{j}]: {list(b)!r} is listed twice")
        bset.add(p)
    inst.blocked = frozenset(bset)

    has_start, has_robots = "start" in d, "robots" in d
    if has_start == has_robots:
        _fail("instance: exactly one of 'start' and 'robots' must be present")
    robots_raw = []
    if has_start:
        robots_raw.append(({k: d[k] for k in ("start", "end", "max_moves") if k in d}, ""))
        inst.fleet = False
    else:
        for k in ("end", "max_moves"):
            if k in d:
                _fail(f"{k}: top-level '{k}' is not allowed with 'robots' (give it per robot)")
        rr = d["robots"]
        if not isinstance(rr, list) or len(rr) < 1:
            _fail(f"robots: {rr!r} must be a non-empty list")
        for j, r in enumerate(rr):
            _keys(r, _ROBOT_KEYS, f"robots[{j}]")
            if "start" not in r:
                _fail(f"robots[{j}].start: missing")
            robots_raw.append((r, f"robots[{j}]."))
        inst.fleet = True

    inst.robots = []
    for r, prefix in robots_raw:
        start = _lattice_point(inst, r["start"], prefix + "start")
        if start in inst.blocked:
            _fail(f"{prefix}start: {list(r['start'])!r} is blocked")
        end = None
        if "end" in r:
            end = _lattice_point(inst, r["end"], prefix + "end")
            if end in inst.blocked:
                _fail(f"{prefix}end: {list(r['end'])!r} is blocked")
        mm = _max_moves(r["max_moves"], prefix + "max_moves") if "max_moves" in r else None
        inst.robots.append(_Robot(start, end, mm))

    # Reachability of each robot's end (section 9): BFS over (point, moves used) from start,
    # moves used <= min(T-1, max_moves); staying is free, so (point, m) reachable means the
    # point can be stood on in the last slot.
    for j, r in enumerate(inst.robots):
        if r.end is None:
            continue
        budget = inst.T - 1 if r.max_moves is None else min(inst.T - 1, r.max_moves)
        seen = {(r.start, 0)}
        queue = deque([(r.start, 0)])
        ok = False
        while queue:
            p, m = queue.popleft()
            if p == r.end:
                ok = True
                break
            if m == budget:
                continue
            for dk, dl in _MOVES[1:]:
                q = (p[0] + dk, p[1] + dl)
                if inst.free(q) and (q, m + 1) not in seen:
                    seen.add((q, m + 1))
                    queue.append((q, m + 1))
        if not ok:
            who = f"robot {j}: " if inst.fleet else ""
            _fail(
                f"{who}end {list(inst.coords(r.end))!r} is unreachable from start "
                f"{list(inst.coords(r.start))!r} within {inst.T - 1} moves (horizon - 1)"
                + ("" if r.max_moves is None else f" and max_moves {r.max_moves}")
                + " around the blocked points: no legal plan"
            )

    # Two robots on one start (slot 0) or one end (slot T-1) admit no legal plan either.
    for a, b in itertools.combinations(range(len(inst.robots)), 2):
        ra, rb = inst.robots[a], inst.robots[b]
        if ra.start == rb.start:
            _fail(
                f"robots[{a}].start and robots[{b}].start: both {list(inst.coords(ra.start))!r}"
                " (two robots on one point in slot 0): no legal plan"
            )
        if ra.end is not None and ra.end == rb.end:
            _fail(
                f"robots[{a}].end and robots[{b}].end: both {list(inst.coords(ra.end))!r}"
                " (two robots on one point in the last slot): no legal plan"
            )
    return inst


def check_instance(d: dict) -> None:
    """Raise OracleError(reason) if d breaks MODEL.md sections 1, 2, 9 or 10."""
    _parse(d)


# ----------------------------------------------------------------------------------------
# Simulation
# ----------------------------------------------------------------------------------------


def _voi(inst, i, aoi, q):
    """Section 4: V_i = -B log2(1 - x), x = P g0 rho^A / (B N0 q^2 + P g0), via log1p."""
    s = inst.sensors[i]
    pg = s.power * inst.g0
    x = pg * s.rho**aoi / (inst.B * inst.N0 * q * q + pg)
    return -inst.B * math.log1p(-x) / math.log(2.0)


def _evaluate(inst, trajs):
    """Metrics of section 5 for legal trajectories: list of (positions, schedule) per robot."""
    n = len(inst.sensors)
    aoi = [s.a0 for s in inst.sensors]
    q = [s.q0 for s in inst.sensors]
    min_voi = math.inf
    sum_min = 0.0
    max_aoi = 0
    sum_max = 0
    for t in range(inst.T):
        uploads = {}
        for positions, schedule in trajs:
            u = schedule[t]
            if u is not None:
                uploads[u] = inst.distance(positions[t], u)
        for i in range(n):  # state of slot t+1
            if i in uploads:
                aoi[i] = 1
                q[i] = uploads[i]
            else:
                aoi[i] += 1
        v = min(_voi(inst, i, aoi[i], q[i]) for i in range(n))
        min_voi = min(min_voi, v)
        sum_min += v
        a = max(aoi)
        max_aoi = max(max_aoi, a)
        sum_max += a
    return {
        "min-voi": min_voi,
        "mean-min-voi": sum_min / inst.T,
        "max-aoi": max_aoi,
        "mean-max-aoi": sum_max / inst.T,
    }


def _parse_plan(inst, plan):
    """Legal trajectories [(positions [(k, l)], schedule [int|None])] or OracleError."""
    K, T, n = len(inst.robots), inst.T, len(inst.sensors)
    if not isinstance(plan, dict):
        _fail(f"plan: {plan!r} is not an object")
    if "robots" in plan:
        if set(plan) != {"robots"}:
            _fail(f"plan: unknown field(s) {sorted(set(plan) - {'robots'})} beside 'robots'")
        entries = plan["robots"]
        if not isinstance(entries, list) or len(entries) != K:
            _fail(f"plan: wrong length: 'robots' must be a list of {K} entries, got {entries!r}")
        fleet_form = True
    else:
        if K != 1:
            _fail(f"plan: the flat form is for one robot, the instance has {K}")
        entries = [plan]
        fleet_form = False

    trajs = []
    for k, entry in enumerate(entries):
        who = f"robot {k}, " if fleet_form else ""
        if not isinstance(entry, dict) or set(entry) != {"positions", "schedule"}:
            _fail(f"{who}plan entry must have exactly 'positions' and 'schedule', got {entry!r}")
        pos_raw, sched_raw = entry["positions"], entry["schedule"]
        if not isinstance(pos_raw, list) or len(pos_raw) != T:
            _fail(
                f"{who}positions: wrong length {len(pos_raw) if isinstance(pos_raw, list) else pos_raw!r}, "
                f"expected horizon {T}"
            )
        if not isinstance(sched_raw, list) or len(sched_raw) != T:
            _fail(
                f"{who}schedule: wrong length {len(sched_raw) if isinstance(sched_raw, list) else sched_raw!r}, "
                f"expected horizon {T}"
            )
        robot = inst.robots[k]
        positions, schedule = [], []
        moves = 0
        for t in range(T):
            where = f"{who}slot {t}"
            p = _lattice_point(inst, pos_raw[t], f"{where}: position")
            if p in inst.blocked:
                _fail(f"{where}: position {pos_raw[t]!r} is blocked")
            if t == 0:
                if p != robot.start:
                    _fail(
                        f"{where}: start mismatch: {pos_raw[t]!r} != start "
                        f"{list(inst.coords(robot.start))!r}"
                    )
            else:
                prev = positions[-1]
                if abs(p[0] - prev[0]) + abs(p[1] - prev[1]) > 1:
                    _fail(f"{where}: illegal move from {pos_raw[t - 1]!r} to {pos_raw[t]!r}")
                if p != prev:
                    moves += 1
                    if robot.max_moves is not None and moves > robot.max_moves:
                        _fail(
                            f"{where}: too many moves: move number {moves} exceeds max_moves "
                            f"{robot.max_moves}"
                        )
            u = sched_raw[t]
            if u is not None:
                if not _is_int(u) or not 0 <= u < n:
                    _fail(f"{where}: schedule entry {u!r} is not a sensor index 0..{n - 1} or null")
                dist = inst.distance(p, u)
                if dist > inst.d_th + TOL:
                    _fail(
                        f"{where}: sensor {u} out of range: distance {dist!r} > d_th {inst.d_th!r}"
                    )
            positions.append(p)
            schedule.append(u)
        if robot.end is not None and positions[-1] != robot.end:
            _fail(
                f"{who}slot {T - 1}: end not reached: {pos_raw[T - 1]!r} != end "
                f"{list(inst.coords(robot.end))!r}"
            )
        trajs.append((positions, schedule))

    for t in range(T):
        for a, b in itertools.combinations(range(K), 2):
            (pa, sa), (pb, sb) = trajs[a], trajs[b]
            if sa[t] is not None and sa[t] == sb[t]:
                _fail(f"robots {a} and {b}, slot {t}: sensor {sa[t]} scheduled by two robots")
            if pa[t] == pb[t]:
                _fail(
                    f"robots {a} and {b}, slot {t}: two robots on the same point "
                    f"{list(inst.coords(pa[t]))!r}"
                )
            if t + 1 < T and pa[t] != pb[t] and pa[t + 1] == pb[t] and pb[t + 1] == pa[t]:
                _fail(
                    f"robots {a} and {b}, slot {t}: swap of points "
                    f"{list(inst.coords(pa[t]))!r} and {list(inst.coords(pb[t]))!r} "
                    f"between slots {t} and {t + 1}"
                )
    return trajs


def simulate(d: dict, plan: dict) -> dict:
    """The four metrics of section 5 of plan; OracleError for an illegal instance or plan."""
    inst = _parse(d)
    return _evaluate(inst, _parse_plan(inst, plan))


# ----------------------------------------------------------------------------------------
# Enumeration
# ----------------------------------------------------------------------------------------


def _dist_to_end(inst, end):
    """BFS distance (in moves, around blocked points) from every free point to end."""
    if end is None:
        return None
    dist = {end: 0}
    queue = deque([end])
    while queue:
        p = queue.popleft()
        for dk, dl in _MOVES[1:]:
            q = (p[0] + dk, p[1] + dl)
            if inst.free(q) and q not in dist:
                dist[q] = dist[p] + 1
                queue.append(q)
    return dist


def _joint_uploads(inst, cur):
    """Every joint upload choice at joint position cur, in order (None first, then indices)."""
    per = [[None] + [i for i in range(len(inst.sensors)) if inst.in_range(p, i)] for p in cur]
    for combo in itertools.product(*per):
        ids = [u for u in combo if u is not None]
        if len(ids) == len(set(ids)):
            yield combo


def _joint_moves(inst, dists, t, cur, used):
    """Every legal joint next position for slot t+1 (t+1 <= T-1): (next, used') pairs."""
    per = []
    for k, r in enumerate(inst.robots):
        p = cur[k]
        opts = []
        for dk, dl in _MOVES:
            q = (p[0] + dk, p[1] + dl)
            if not inst.free(q):
                continue
            u = used[k] + (q != p)
            if r.max_moves is not None and u > r.max_moves:
                continue
            if r.end is not None:
                need = dists[k].get(q)
                slots_left = inst.T - 1 - (t + 1)  # moves still possible after slot t+1
                if need is None or need > slots_left:
                    continue
                if r.max_moves is not None and need > r.max_moves - u:
                    continue
            opts.append((q, u))
        per.append(opts)
    for combo in itertools.product(*per):
        nxt = tuple(q for q, _ in combo)
        if len(set(nxt)) < len(nxt):
            continue
        if any(
            nxt[a] == cur[b] and nxt[b] == cur[a]
            for a, b in itertools.combinations(range(len(nxt)), 2)
        ):
            continue
        yield nxt, tuple(u for _, u in combo)


def _start_state(inst):
    cur = tuple(r.start for r in inst.robots)
    dists = [_dist_to_end(inst, r.end) for r in inst.robots]
    return cur, tuple(0 for _ in inst.robots), dists


def _iter_trajs(inst):
    """Depth-first over slots: joint upload of slot t, then joint move to slot t+1."""
    cur, used, dists = _start_state(inst)
    K, T = len(inst.robots), inst.T
    if len(set(cur)) < K:
        return
    pos = [[p] for p in cur]
    sched = [[] for _ in range(K)]

    def rec(t, cur, used):
        for up in _joint_uploads(inst, cur):
            for k in range(K):
                sched[k].append(up[k])
            if t == T - 1:
                yield [(list(pos[k]), list(sched[k])) for k in range(K)]
            else:
                for nxt, used2 in _joint_moves(inst, dists, t, cur, used):
                    for k in range(K):
                        pos[k].append(nxt[k])
                    yield from rec(t + 1, nxt, used2)
                    for k in range(K):
                        pos[k].pop()
            for k in range(K):
                sched[k].pop()

    yield from rec(0, cur, used)


def _to_plan(inst, trajs):
    entries = [
        {"positions": [list(inst.coords(p)) for p in positions], "schedule": list(schedule)}
        for positions, schedule in trajs
    ]
    return {"robots": entries} if inst.fleet else entries[0]


def legal_plans(d: dict):
    """Generate every legal plan of d (flat form for a `start` instance), in DFS order."""
    inst = _parse(d)
    for trajs in _iter_trajs(inst):
        yield _to_plan(inst, trajs)


def count_legal_plans(d: dict) -> int:
    """The number of legal plans, by memoised recursion over (slot, joint point, moves used)."""
    inst = _parse(d)
    cur, used, dists = _start_state(inst)
    if len(set(cur)) < len(cur):
        return 0
    memo = {}

    def count(t, cur, used):
        key = (t, cur, used)
        if key not in memo:
            n_up = sum(1 for _ in _joint_uploads(inst, cur))
            if t == inst.T - 1:
                memo[key] = n_up
            else:
                memo[key] = n_up * sum(
                    count(t + 1, nxt, u2) for nxt, u2 in _joint_moves(inst, dists, t, cur, used)
                )
        return memo[key]

    return count(0, cur, used)


def brute_force(d: dict, objective: str, max_plans: int = 200_000):
    """(optimum, one optimal plan) by evaluating every legal plan; ties keep the first."""
    if objective not in OBJECTIVES:
        _fail(f"objective: {objective!r} is not one of {sorted(OBJECTIVES)}")
    maximise = OBJECTIVES[objective]
    inst = _parse(d)
    total = count_legal_plans(d)
    if total == 0:
        _fail("instance admits no legal (joint) plan")
    if total > max_plans:
        _fail(f"too many plans for brute force: {total} > {max_plans}")
    best_val, best = None, None
    for trajs in _iter_trajs(inst):
        val = _evaluate(inst, trajs)[objective]
        if best is None or (val > best_val if maximise else val < best_val):
            best_val, best = val, trajs
    plan = _to_plan(inst, best)
    again = simulate(d, plan)[objective]  # full legality check of the winner
    if again != best_val:
        _fail(f"internal: optimum {best_val!r} re-simulates to {again!r}")
    return best_val, plan


def random_legal_plan(d: dict, rng, attempts: int = 1000):
    """A random legal plan: a random walk drawing each slot's joint upload and joint move
    uniformly among the legal ones (end reachability by BFS distances and the move budget
    respected); a walk that gets stuck (robots blocking each other) is rejected and redrawn."""
    inst = _parse(d)
    K, T = len(inst.robots), inst.T
    for _ in range(attempts):
        cur, used, dists = _start_state(inst)
        if len(set(cur)) < K:
            break
        pos = [[p] for p in cur]
        sched = [[] for _ in range(K)]
        stuck = False
        for t in range(T):
            up = rng.choice(list(_joint_uploads(inst, cur)))
            for k in range(K):
                sched[k].append(up[k])
            if t == T - 1:
                break
            options = list(_joint_moves(inst, dists, t, cur, used))
            if not options:
                stuck = True
                break
            cur, used = rng.choice(options)
            for k in range(K):
                pos[k].append(cur[k])
        if not stuck:
            plan = _to_plan(inst, list(zip(pos, sched, strict=True)))
            simulate(d, plan)  # must be legal
            return plan
    _fail(f"no legal random walk found in {attempts} attempts")
