"""``make demo``: the main job on the shipped case study.

Solves the case study with the exact methods (dp, milp), the paper's Q-learning (VoI and AoI
rewards, paper defaults, several seeds) and the baselines, prints their simulated values side
by side with each plan's proven gap to the optimum, and writes the results to out/demo/.
"""

from __future__ import annotations

import os
import shutil
import statistics
import sys
from pathlib import Path

from rich.console import Console
from rich.table import Table

from voiopt import objectives
from voiopt.core import instance
from voiopt.core.result import Result
from voiopt.networks.generate import case_study, case_study_plan
from voiopt.objectives import DEFAULT as OBJECTIVE
from voiopt.objectives import OBJECTIVES
from voiopt.runtime.files import safe_name
from voiopt.runtime.status import Status
from voiopt.runtime.stop import Interrupted, watch
from voiopt.solvers import RANDOMISED, solve

SEEDS = (0, 1, 2)
RUNS = [  # (label, method, what it is, options)
    ("dp", "dp", "exact label-setting programme: the proven optimum", {}),
    ("milp", "milp", "exact MILP on HiGHS, warm-started from the dp plan", {"time_limit": 120.0}),
    ("qlearning", "qlearning", "the paper's 'VoI-optimal' Q-learning as written: V in bit/s, penalty 100, 1e6 episodes", {}),
    ("aoi-qlearning", "aoi-qlearning", "the paper's 'AoI-optimal' Q-learning (AoI reward)", {}),
    ("qlearning bit/s/Hz", "qlearning", "the same with V / B (an earlier reading, for comparison)",
     {"reward_units": "bit/s/Hz"}),
    ("shortest-path", "shortest-path", "the paper's shortest-path scheme", {}),
    ("greedy", "greedy", "one-step greedy", {}),
]


def run_demo(path: str | None, console: Console, out_dir: str | Path = "out/demo") -> int:
    if not console.is_terminal:  # rich assumes 80 columns when piped; the table needs more
        console = Console(width=max(console.width, 120), highlight=False)
    inst = instance.load(path) if path else case_study()
    console.print(
        f"[bold]{inst.name}[/]: N = {inst.n_sensors} sensors, T = {inst.horizon} slots, "
        f"{inst.width:g} x {inst.height:g} m area, start {list(inst.start)}; objective {OBJECTIVE}"
    )
    results: list[tuple[str, Result]] = []  # (row label, result)
    with watch() as stop:  # Ctrl-C stops the demo as a whole, not one solve after another
        _run_all(inst, console, Path(out_dir), results, stop)
    if stop.requested:
        raise Interrupted(stop.signal)
    if not path:
        example = Result.from_plan(inst, "example", OBJECTIVE, case_study_plan(), status=Status.FEASIBLE)
        results.append(("example", example))
        console.print("example: the hand-made plan shipped in instances/case-study.plan.json", style="dim")
    _report(inst, console, Path(out_dir), results)
    return 0


def _run_all(inst, console: Console, out_dir: Path, results: list[tuple[str, Result]], stop) -> None:
    dp_plan = None
    for label, method, what, options in RUNS:
        opts = dict(options)
        if method == "milp" and dp_plan is not None:
            opts["warm_start"] = dp_plan
        seeds = SEEDS if method in RANDOMISED else (None,)
        console.print(f"{label}: {what}" + (f"; seeds {SEEDS[0]}-{SEEDS[-1]}" if seeds[0] is not None else ""),
                      style="dim")
        for seed in seeds:
            if stop.requested:
                return
            if seed is not None:
                opts["seed"] = seed
            # progress bars for the long trainings; the solvers' own logs would drown the table
            r = solve(inst, method=method, objective=OBJECTIVE, progress=method in RANDOMISED, **opts)
            if method == "dp":
                dp_plan = r.plan
            stem = label.replace(" ", "-").replace("/", "-per-")
            r.save(out_dir / f"{safe_name(inst.name)}__{stem}{'' if seed is None else f'__seed{seed}'}.json")
            results.append((label if seed is None else f"{label} (seed {seed})", r))


def _merged(results: list[tuple[str, Result]]) -> list[tuple[str, list[Result]]]:
    """The table's rows: a randomised method's seeds in one row, "(seed 0..2)", when every seed
    gave the same status and metrics; else a row per seed."""
    groups: dict[str, list[tuple[str, Result]]] = {}
    for label, r in results:
        groups.setdefault(label.split(" (seed ")[0], []).append((label, r))
    rows = []
    for base, members in groups.items():
        seeds = [label.split(" (seed ")[1].rstrip(")") for label, _ in members if " (seed " in label]
        same = len({(r.status, tuple(sorted((r.metrics or {}).items()))) for _, r in members}) == 1
        if len(seeds) > 1 and len(seeds) == len(members) and same:
            rows.append((f"{base} (seed {seeds[0]}..{seeds[-1]})", [r for _, r in members]))
        else:
            rows += [(label, [r]) for label, r in members]
    return rows


def _report(inst, console: Console, out_dir: Path, results: list[tuple[str, Result]]) -> None:
    best_bound = objectives.tightest(OBJECTIVE, (r.bound for _, r in results))
    table = Table(title=f"{inst.name}: every value simulated from the plan; gap = proven distance to the optimum")
    for col in ("plan", "status", *OBJECTIVES, "gap", "time"):
        table.add_column(col, justify="left" if col in ("plan", "status") else "right")
    for label, runs in _merged(results):
        r = runs[0]
        gap = objectives.gap(r.value, best_bound)
        times = sorted(x.runtime_s for x in runs)
        table.add_row(label, r.status, *(f"{r.metrics[m]:.6g}" for m in OBJECTIVES),
                      "-" if gap is None else percent(gap),
                      f"{times[0]:.2f} s" if len(runs) == 1 else f"{times[0]:.2f}-{times[-1]:.2f} s")
    console.print(table)
    if best_bound:
        for label, reading in (("qlearning", "V in bit/s, penalty 100: the paper as written"),
                               ("qlearning bit/s/Hz", "V / B, penalty 100")):
            runs = [r for row, r in results if row.startswith(f"{label} (seed") and r.status in (Status.OPTIMAL, Status.FEASIBLE)]
            if not runs:
                continue
            gaps = [objectives.gap(r.value, best_bound) for r in runs]
            console.print(
                f"The paper's Q-learning ({reading}), seeds {SEEDS[0]}-{SEEDS[-1]}: mean {statistics.fmean(r.value for r in runs):.6g} "
                f"bit/s of a proven optimum of {best_bound:.6g} bit/s, a certified gap of "
                f"{percent(statistics.fmean(gaps))} on average (min {percent(min(gaps))}, max {percent(max(gaps))})."
            )
    console.print("(times exclude numba's one-off compilation, recorded as solver.startup_s)", style="dim")
    console.print(f"results written to {out_dir}/ (plot one with: {command()} plot {out_dir}/{safe_name(inst.name)}__dp.json "
                  "-o dp.png)")


def percent(g: float) -> str:
    """A gap as the table and the closing lines show it: two decimals of a percent."""
    return f"{100 * g:.2f} %"


def command() -> str:
    """How to run voiopt again from this shell: ``voiopt`` if it is on PATH and is this one,
    else this Python's ``-m voiopt`` (after ``make demo`` the command is in .venv/bin, not on PATH)."""
    found = shutil.which("voiopt")
    here = Path(sys.executable).parent / "voiopt"
    if found is not None and Path(found).resolve() == here.resolve():
        return "voiopt"
    relative = os.path.relpath(sys.executable)
    return f"{sys.executable if relative.startswith('..') else relative} -m voiopt"
