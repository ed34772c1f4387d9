"""``make demo``: the main job on the shipped case study.

Solves the case study with the exact methods (dp, milp), the paper's Q-learning (VoI and
AoI rewards, paper defaults) and the baselines, prints their simulated values side by side
with each plan's proven gap to the optimum, and writes the results to out/demo/.
"""

from __future__ import annotations

from pathlib import Path

from rich.console import Console
from rich.table import Table

from voiopt import instance
from voiopt.generate import CASE_STUDY_PLAN, case_study
from voiopt.result import Plan, Result
from voiopt.simulate import OBJECTIVES, sense
from voiopt.solvers import solve

OBJECTIVE = "mean-min-voi"
RUNS = [  # (method, what it is, options)
    ("dp", "exact label-setting programme: the proven optimum", {}),
    ("milp", "exact MILP on HiGHS, warm-started from the dp plan", {"time_limit": 120.0}),
    ("qlearning", "the paper's 'VoI-optimal' Q-learning, paper defaults (1e6 episodes)", {"seed": 0}),
    ("aoi-qlearning", "the paper's 'AoI-optimal' Q-learning (AoI reward)", {"seed": 0}),
    ("shortest-path", "the paper's shortest-path scheme", {}),
    ("greedy", "one-step greedy", {}),
]


def run_demo(path: str | None, console: Console, out_dir: str | Path = "out/demo") -> int:
    if not console.is_terminal:  # rich assumes 80 columns when piped; the table needs more
        console = Console(width=max(console.width, 110), highlight=False)
    inst = instance.load(path) if path else case_study()
    console.print(
        f"[bold]{inst.name}[/]: N = {inst.n_sensors} sensors, T = {inst.horizon} slots, "
        f"{inst.width:g} x {inst.height:g} m area, start {list(inst.start)}; objective {OBJECTIVE}"
    )
    results: list[tuple[str, Result]] = []
    dp_plan = None
    for method, label, options in RUNS:
        opts = dict(options)
        if method == "milp" and dp_plan is not None:
            opts["warm_start"] = dp_plan
        console.print(f"{method}: {label}", style="dim")
        # progress bars for the long trainings; the solvers' own logs would drown the table
        r = solve(inst, method=method, objective=OBJECTIVE, progress=method.endswith("qlearning"), **opts)
        if method == "dp":
            dp_plan = r.plan
        r.save(Path(out_dir) / f"{inst.name}__{method}.json")
        results.append((method, r))
    if not path:
        example = Result.from_plan(inst, "example", OBJECTIVE, Plan.from_dict(CASE_STUDY_PLAN), status="feasible")
        results.append(("example", example))
        console.print("example: the hand-made plan shipped in instances/case-study.plan.json", style="dim")

    bounds = [r.bound for _, r in results if r.bound is not None]
    best_bound = (min if sense(OBJECTIVE) == "max" else max)(bounds) if bounds else None
    table = Table(title=f"{inst.name}: every value simulated from the plan; gap = proven distance to the optimum")
    for col in ("method", "status", *OBJECTIVES, "gap", "time"):
        table.add_column(col, justify="left" if col in ("method", "status") else "right")
    for label, r in results:
        gap = "-" if best_bound is None else f"{100 * abs(best_bound - r.value) / abs(best_bound):.2f} %"
        table.add_row(label, r.status, *(f"{r.metrics[m]:.6g}" for m in OBJECTIVES), gap, f"{r.runtime_s:.2f} s")
    console.print(table)
    q = dict((r.method, r) for _, r in results).get("qlearning")
    if q is not None and best_bound:
        console.print(
            f"The paper's Q-learning reaches {q.value:.6g} bit/s of a proven optimum of {best_bound:.6g} bit/s: "
            f"a certified gap of {100 * (best_bound - q.value) / best_bound:.1f} %."
        )
    console.print("(times include numba's one-off compilation on the first run of a fresh install)", style="dim")
    console.print(f"results written to {out_dir}/ (plot one with: voiopt plot {out_dir}/{inst.name}__dp.json -o dp.png)")
    return 0
