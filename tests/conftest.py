"""Shared fixtures: tiny random instances for cross-checks against the oracles in tests/oracles/."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # make tests/oracles importable

import voiopt  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def run_cli(capsys, *argv):
    """(exit status, stdout, stderr) of the voiopt command in this process; argparse's own
    errors (SystemExit) count as their status."""
    from voiopt.cli.main import main

    try:
        code = main([str(a) for a in argv])
    except SystemExit as e:
        code = e.code
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def one_line_error(err: str) -> str:
    """The one line of a refusal on stderr (no traceback, nothing else)."""
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def tiny_instances(count: int = 30, seed: int = 12345) -> list[voiopt.Instance]:
    """A varied set of tiny networks: normal, low-VoI (rho small, long horizon), low power."""
    out = []
    kinds = [
        dict(rho=(0.0, 1.0), power_w=1.0),
        dict(rho=(0.05, 0.3), power_w=1.0, initial_aoi=(3, 8)),  # min-VoI optimum far below 1 bit/s
        dict(rho=(0.3, 0.9), power_w=0.01),  # distance matters
        dict(rho=(0.3, 0.9), power_w=0.001),
    ]
    for k in range(count):
        kind = kinds[k % len(kinds)]
        n = 1 + k % 3
        horizon = 3 + k % 4
        size = 2.0 if k % 2 else 3.0
        out.append(
            voiopt.generate(n, horizon, width=size, height=2.0, seed=seed + k, name=f"tiny-{k:02d}", **kind)
        )
    return out


@pytest.fixture(scope="session")
def case_study():
    return voiopt.load(ROOT / "instances" / "case-study.json")


def field_instances(count: int = 24, seed: int = 777) -> list[voiopt.Instance]:
    """Tiny networks with the fields of MODEL.md section 9, each case making one of them (or
    all) bind: random blocked points, an end point, a move budget. Only instances the model
    admits are kept (the loader's BFS decides; the oracle's check_instance must agree)."""
    import math
    import random

    rng = random.Random(seed)
    out = []
    for k, base in enumerate(tiny_instances(4 * count, seed)):
        if len(out) == count:
            break
        d = base.to_dict()
        nx, ny = int(base.width) + 1, int(base.height) + 1
        points = [[x, y] for x in range(nx) for y in range(ny) if [x, y] != list(map(int, base.start))]
        which = k % 4  # 0: blocked, 1: end, 2: max_moves, 3: all three
        if which in (0, 3):  # mostly near sensors, where an obstacle changes what can be uploaded
            near = [p for p in points if any(math.dist(p, s.position) <= 1.5 for s in base.sensors)] or points
            d["blocked"] = rng.sample(near, rng.randint(1, max(1, (len(near) + 1) // 2)))
        if which in (1, 3):
            free = [p for p in points if p not in d.get("blocked", [])]
            d["end"] = rng.choice(free + [list(map(int, base.start))])
        if which in (2, 3):
            d["max_moves"] = rng.randint(0, base.horizon - 1)
        d["name"] = f"field-{k:02d}"
        try:
            out.append(voiopt.core.instance.from_dict(d))
        except voiopt.errors.InstanceError:
            continue
    return out


def fleet_instances(count: int = 12, seed: int = 4242) -> list[voiopt.Instance]:
    """Tiny two-robot networks (MODEL.md section 10) small enough for the oracle's brute force
    (2 x 2 or 3 x 2 lattices, T = 2..3, N = 1..3): robots start side by side, so the rules
    between robots bind (no shared point, no swap, a sensor uploads to one robot per slot);
    some cases add section 9's fields per robot (an end, a budget, a blocked point)."""
    import random

    from oracles import model_oracle as oracle

    rng = random.Random(seed)
    out = []
    k = 0
    while len(out) < count:
        k += 1
        horizon = 2 + k % 3
        base = voiopt.generate(1 + k % (2 if horizon == 4 else 3), horizon, width=1.0 + (k % 4 == 3), height=1.0, seed=seed + k,
                               name=f"fleet-{len(out):02d}", rho=(0.2, 0.95), power_w=rng.choice([1.0, 0.01]))
        d = base.to_dict()
        del d["start"]
        points = [[x, y] for x in range(int(base.width) + 1) for y in range(int(base.height) + 1)]
        a, b = rng.sample(points, 2)
        robots = [{"start": a}, {"start": b}]
        which = k % 4  # 0: plain, 1: ends, 2: a budget, 3: a blocked point and an end
        if which in (1, 3):
            free = [p for p in points if p not in (a, b)] if which == 3 else points
            robots[0]["end"], robots[1]["end"] = rng.sample(free, 2)
        if which == 2:
            robots[rng.randint(0, 1)]["max_moves"] = rng.randint(0, 1)
        if which == 3:
            d["blocked"] = [rng.choice([p for p in points if p not in (a, b, robots[0]["end"], robots[1]["end"])]
                                       or [a])]
        d["robots"] = robots
        try:
            inst = voiopt.core.instance.from_dict(d)
        except voiopt.errors.InstanceError:
            continue
        if 0 < oracle.count_legal_plans(d) <= 10_000:  # none: ends that only a swap could reach
            out.append(inst)
    return out


# two robots that could pass each other only by a swap (the oracle counts no legal plan)
SWAP_ONLY = {"name": "swap-only", "area": {"width": 2, "height": 1}, "horizon": 10,
             "robots": [{"start": [0, 0], "end": [0, 1]}, {"start": [1, 1], "end": [0, 0]}],
             "blocked": [[1, 0]],
             "sensors": [{"position": [0.54, 0.8], "rho": 0.519}, {"position": [1.72, 0.4], "rho": 0.414}]}


def undecided(d: dict) -> voiopt.Instance:
    """The instance of ``d`` as the loader admits a fleet too large for its check that some
    joint plan exists (voiopt.grid.joint.possible answers None): the solvers must then prove that
    none exists themselves, and say ``infeasible``."""
    from voiopt.grid import joint

    possible = joint.possible
    joint.possible = lambda *args: None
    try:
        return voiopt.core.instance.from_dict(d)
    finally:
        joint.possible = possible


_FLEET_OPTIMA: dict[str, dict[str, float]] = {}


def oracle_optima(inst: voiopt.Instance) -> dict[str, float]:
    """The oracle's optimum of every objective, from one enumeration of the legal plans
    (cached for the session: several test modules ask for the same tiny instances)."""
    import json

    from oracles import model_oracle as oracle

    d = inst.to_dict()
    key = json.dumps(d, sort_keys=True)
    if key not in _FLEET_OPTIMA:
        best: dict[str, float] = {}
        for plan in oracle.legal_plans(d):
            for ob, v in oracle.simulate(d, plan).items():
                if ob not in best or (v > best[ob] if oracle.OBJECTIVES[ob] else v < best[ob]):
                    best[ob] = v
        _FLEET_OPTIMA[key] = best
    return _FLEET_OPTIMA[key]


def solve_model_file(model, solution=None):
    """An exported MPS or LP read by HiGHS and solved to a zero gap (the solution written to
    ``solution`` if given); returns the Highs object."""
    import highspy

    h = highspy.Highs()
    h.silent()
    h.setOptionValue("mip_rel_gap", 0.0)
    assert h.readModel(str(model)) == highspy.HighsStatus.kOk
    h.run()
    if solution is not None:
        h.writeSolution(str(solution), 0)
    return h


@contextlib.contextmanager
def sigint_after(seconds: float):
    """Ctrl-C (SIGINT to this process) after ``seconds``, unless the block ends first."""
    timer = threading.Timer(seconds, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        yield
    finally:
        timer.cancel()


def stop_at_check(monkeypatch, n: int) -> None:
    """The stop rule fires from its n-th check on (a time limit reached: every Stop alive, as
    a solver's and the baseline it runs inside share one clock), wherever the clock is:
    mid-walk, mid-build, deterministically."""
    from voiopt.runtime import stop as stop_mod

    calls = {"n": 0}
    check = stop_mod.Stop.check

    def late_check(self, memory_used=0.0):
        calls["n"] += 1
        if calls["n"] >= n and not self.requested:
            self.request(stop_mod.TIME_LIMIT)
        return check(self, memory_used)

    monkeypatch.setattr(stop_mod.Stop, "check", late_check)


def pytest_terminal_summary(terminalreporter):
    """Say plainly, at the end of the run, when the browser tests of the viewer did not run
    (no Chromium here: .ci/run installs it, so CI always runs them)."""
    skipped = [r for r in terminalreporter.stats.get("skipped", [])
               if "browser tests did not run" in str(getattr(r, "longrepr", ""))]
    if skipped:
        reason = str(skipped[0].longrepr[-1]) if isinstance(skipped[0].longrepr, tuple) else str(skipped[0].longrepr)
        terminalreporter.write_sep("!", "BROWSER TESTS DID NOT RUN", red=True, bold=True)
        terminalreporter.write_line(f"{len(skipped)} test(s) of voiopt show in headless Chromium were skipped: {reason}")


WARM_UP = (  # every family of numba kernels, compiled (or loaded from numba's cache) once
    "from voiopt.solvers.dp import fleet, solver\n"
    "from voiopt.solvers.qlearning import lossy\n"
    "from voiopt.solvers.qlearning import solver as ql\n"
    "solver.warm_up(); fleet.warm_up(); ql.warm_up(); ql.warm_up(fleet=True); lossy.warm_up()\n"
)


def pytest_configure(config):
    """With xdist workers, compile the kernels once, before the workers start: otherwise each
    worker compiles the same kernels at the same time (on a fresh clone about 50 s of work
    done twice). Afterwards numba's disk cache makes this about a second."""
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    import subprocess

    print("compiling voiopt's numba kernels once before the workers start (cached afterwards) ...", flush=True)
    subprocess.run([sys.executable, "-c", WARM_UP], check=True, cwd=Path(__file__).resolve().parent.parent)
