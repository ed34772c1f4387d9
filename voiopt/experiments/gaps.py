"""Gap reports: every method on every network (randomised ones over several seeds), each
plan's proven gap to the tightest bound of its network, as gaps.csv, summary.md and gaps.png.
On lossy instances (MODEL.md section 11) values and bounds are labelled, and the headline gap
is to a proven bound only (voiopt.experiments.lossy_gaps)."""

from __future__ import annotations

import os
import statistics
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import Any

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.links import is_lossy
from voiopt.core.result import Result, load_result
from voiopt.errors import InstanceError, MemoryLimitError, OptionError, PlanError, VoioptError
from voiopt.experiments.lossy_gaps import (
    LOSSY_COLUMNS,
    check_samples,
    lossy_fields,
    lossy_markdown,
    proven,
)
from voiopt.experiments.plots import plot_gaps
from voiopt.experiments.runner import (
    Task,
    check_manifest,
    check_methods,
    freed_unless_stored,
    load_instances,
    method_tasks,
    run_options,
    run_tasks,
)
from voiopt.objectives import Worth
from voiopt.runtime.files import atomic_write, check_output_dir, write_csv
from voiopt.runtime.status import Status
from voiopt.solvers import RANDOMISED
from voiopt.solvers.base import DEFAULT_MEMORY_GB

GAP_COLUMNS = ["instance", "method", "seed", "objective", "status", "value", "bound", "best_value", "best_bound",
               "gap", "runtime_s", "cause", "reward_units"]
NORMAL = (Status.OPTIMAL, Status.FEASIBLE)  # every other status is counted and explained in summary.md


def cause(r: Result) -> str:
    """Why a run ended as it did, when it did not end normally: the solver's own words."""
    if r.status in NORMAL:
        return ""
    why = str(r.solver.get("error") or r.solver.get("stopped") or r.solver.get("note") or r.status)
    kind, _, message = why.partition(": ")  # a bad input's plain message: "OptionError: " says nothing to a reader
    return message if message and kind in PLAIN else why


PLAIN = {c.__name__ for c in (VoioptError, InstanceError, PlanError, OptionError, MemoryLimitError)}


def plan_tasks(
    instances: Sequence[tuple[Path, Instance]], methods: Sequence[str], objective: str, out_dir: Path,
    seed: int = 0, seeds: int = 1, **options: Any,
) -> list[Task]:
    tasks = []
    for p, inst in instances:
        tasks += method_tasks(inst, p, methods, objective, out_dir / "results", seed, seeds, **options)
    return tasks


def gap_rows(results: Sequence[Result], objective: str, seeds: Sequence[int | None] | None = None,
             lossy: Collection[str] | None = None) -> list[dict[str, Any]]:
    """One row per result, with the best plan value and tightest proven bound of its instance
    (over every method and seed); ``seeds`` gives each result's seed (None: deterministic).
    A row of a lossy instance (named in ``lossy``; None: one with a labelled result) also has
    the LOSSY_COLUMNS (lossy_gaps.lossy_fields)."""
    seeds = list(seeds) if seeds is not None else [None] * len(results)
    by_instance: dict[str, list[Result]] = {}
    for r in results:
        by_instance.setdefault(r.instance, []).append(r)
    rows = []
    for r, seed in zip(results, seeds, strict=True):
        group = by_instance[r.instance]
        best_value = objectives.best(objective, (g.value for g in group))
        best_bound = objectives.tightest(objective, (g.bound for g in group if proven(g)))
        gap = objectives.gap(r.value, best_bound)
        row = {
            "instance": r.instance, "method": r.method, "seed": seed, "objective": r.objective, "status": r.status,
            "value": r.value, "bound": r.bound, "best_value": best_value, "best_bound": best_bound,
            "gap": gap, "runtime_s": r.runtime_s, "cause": cause(r),
            # Q-learning's reading of V in its reward (MODEL.md section 7); the AoI reward has no V
            "reward_units": r.solver.get("reward_units", "") if r.solver.get("reward") != Worth.AOI else "",
        }
        if r.instance in lossy if lossy is not None else any(g.evaluation is not None for g in group):
            row.update(lossy_fields(r, group, objective))
        rows.append(row)
    return rows


def columns(rows: Sequence[dict[str, Any]]) -> list[str]:
    """gaps.csv's columns: GAP_COLUMNS, and the LOSSY_COLUMNS where some instance is lossy (a
    lossless report's file is as it always was)."""
    return GAP_COLUMNS + (LOSSY_COLUMNS if any("evaluation" in r for r in rows) else [])


def summarise(rows: Sequence[dict[str, Any]], methods: Sequence[str]) -> list[dict[str, Any]]:
    """Per method: gaps over every run (seeds and networks), as mean, min, max and median."""
    out = []
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        gaps = [r["gap"] for r in mine if r["gap"] is not None]
        times = [r["runtime_s"] for r in mine if r["status"] != Status.ERROR]
        seeds = sorted({r["seed"] for r in mine if r.get("seed") is not None})
        out.append({
            "method": m,
            "instances": len({r["instance"] for r in mine}),
            "runs": len(mine),
            "seeds": seeds,
            "optimal": sum(r["status"] == Status.OPTIMAL for r in mine),
            "errors": sum(r["status"] == Status.ERROR for r in mine),
            "other": _count_statuses(r["status"] for r in mine if r["status"] not in NORMAL),
            "median_gap": statistics.median(gaps) if gaps else None,
            "mean_gap": statistics.fmean(gaps) if gaps else None,
            "min_gap": min(gaps) if gaps else None,
            "max_gap": max(gaps) if gaps else None,
            "within_1pct": sum(g <= 0.01 for g in gaps),
            "with_gap": len(gaps),
            "median_runtime_s": statistics.median(times) if times else None,
        })
    return out


def _count_statuses(statuses) -> str:
    counts: dict[str, int] = {}
    for s in statuses:
        counts[s] = counts.get(s, 0) + 1
    return ", ".join(f"{n} {s}" for s, n in sorted(counts.items())) or "0"


def _seed_text(seeds: Sequence[int]) -> str:
    if not seeds:
        return "-"
    if seeds == list(range(seeds[0], seeds[-1] + 1)) and len(seeds) > 2:
        return f"{seeds[0]}-{seeds[-1]}"
    return ", ".join(map(str, seeds))


def summary_markdown(summary: Sequence[dict[str, Any]], objective: str, n_instances: int,
                     reward_units: str | None = None, rows: Sequence[dict[str, Any]] = (),
                     notes: Sequence[str] = (), episodes: int | None = None) -> str:
    lossy = any(r.get("evaluation") is not None for r in rows)
    lines = [
        f"# Gap report: {objective}",
        "",
        f"{n_instances} instance(s). The gap of a plan is its relative distance to the tightest "
        "proven bound over all methods for that instance (a proven optimality gap; exact when "
        "an exact method proved optimality). Every value is simulated from the plan"
        + (", or on a lossy instance is its expectation, exact or Monte Carlo (below). " if lossy else ". ") +
        "A randomised method runs once per seed; its mean, min and max gap are over every seed "
        "and network (one seed is an anecdote).",
    ]
    if reward_units is not None:
        lines.append(f"Q-learning: {episodes or 'the paper default (1e6)'} episodes per run; reward reading: V in "
                     f"{reward_units}, idle penalty 100 (MODEL.md section 7).")
    lines += [
        "",
        "| method | instances | seeds | runs | proven optimal | errors | not finished normally | mean gap | min gap | max gap | median gap | within 1 % | median runtime |",
        "|---|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|",
    ]
    for s in summary:
        rt = "-" if s["median_runtime_s"] is None else f"{s['median_runtime_s']:.3g} s"
        gaps = " | ".join(objectives.show_gap(s[k]) for k in ("mean_gap", "min_gap", "max_gap", "median_gap"))
        within = f"{s['within_1pct']}/{s['with_gap']}" if s["with_gap"] else "-"  # of the runs with a proven gap
        lines.append(
            f"| {s['method']} | {s['instances']} | {_seed_text(s['seeds'])} | {s['runs']} | {s['optimal']} | "
            f"{s['errors']} | {s['other']} | {gaps} | {within} | {rt} |"
        )
    odd = [r for r in rows if r["status"] not in NORMAL]
    if odd:
        lines += ["", "Runs that did not finish normally (their gap still counts where they returned a plan):", ""]
        lines += [f"- {r['instance']}, {r['method']}" + ("" if r.get("seed") is None else f", seed {r['seed']}")
                  + f": {r['status']}: {r['cause']}" for r in odd]
    if summary and not any(s["with_gap"] for s in summary):
        lines += ["", "No method proved a bound on these instances, so there is no gap: add an exact method "
                      "(dp or milp) to measure one."]
    lines += lossy_markdown(rows)
    if notes:
        lines += ["", *[f"- {n}" for n in notes]]
    lines += ["", "![gap distributions](gaps.png)", ""]
    return "\n".join(lines)


def gap_report(
    instances: Sequence[str | os.PathLike],
    methods: Sequence[str],
    objective: str,
    out_dir: str | os.PathLike,
    *,
    time_limit: float | None = None,
    memory_limit: float = DEFAULT_MEMORY_GB,
    episodes: int | None = None,
    seed: int = 0,
    seeds: int = 3,
    reward_units: str = "bit/s",
    workers: int = 1,
    dask_scheduler: str | None = None,
    progress: bool = False,
    notes: list[str] | None = None,
    samples: int | None = None,
    ir_samples: int | None = None,
) -> list[dict[str, Any]]:
    """Run every (instance, method, seed), then write gaps.csv, summary.md and gaps.png.
    Randomised methods run with seeds seed .. seed + seeds - 1; the others once. Everything
    is checked before any work, and run.json is written only then. ``notes`` collects lines
    for the user (files skipped). ``samples`` and ``ir_samples`` go to the methods that take
    them (replan, qlearning on lossy links: Monte Carlo scenarios, information relaxation)."""
    objective = objectives.get(objective)
    methods = check_methods(methods)
    options = run_options(time_limit=time_limit, memory_limit=memory_limit, episodes=episodes,
                          reward_units=reward_units, seeds=seeds, workers=workers, dask_scheduler=dask_scheduler,
                          seed=seed) | check_samples(samples, ir_samples)
    out = check_output_dir(out_dir)
    notes = [] if notes is None else notes
    instances_found = load_instances(instances, notes)
    tasks = plan_tasks(instances_found, methods, objective, out, seed=seed, seeds=seeds, **options)
    created = check_manifest(out, {"command": "gap-report", "objective": objective, "seed": seed, "seeds": seeds,
                                   **options})
    with freed_unless_stored(out, created):
        run_tasks(tasks, workers=workers, dask_scheduler=dask_scheduler, progress=progress, description="runs",
                  notes=notes)
    results = [load_result(t.out_path) for t in tasks]
    rows = gap_rows(results, objective, [t.seed for t in tasks], {i.name for _, i in instances_found if is_lossy(i)})
    write_csv(out / "gaps.csv", rows, columns(rows))
    n_instances = len({t.instance_name for t in tasks})
    summary = summarise(rows, methods)
    uses_q = any(m in RANDOMISED for m in methods)
    md = summary_markdown(summary, objective, n_instances, reward_units if uses_q else None, rows, notes, episodes)
    with atomic_write(out / "summary.md") as f:
        f.write(md)
    about = f"{n_instances} network{'s' if n_instances != 1 else ''}"
    if uses_q:
        about += f"; Q-learning {(episodes or 1_000_000):,} episodes, {seeds} seed{'s' if seeds != 1 else ''}, V in {reward_units}"
    plot_gaps(rows, methods, out / "gaps.png", objective, about)
    return rows
