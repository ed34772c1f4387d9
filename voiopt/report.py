"""Gap reports and sweeps: many (instance, method) pairs, run in a process pool or on Dask.

Each pair's result is written to ``results/INSTANCE__METHOD.json`` as soon as it finishes,
so an interrupted or crashed sweep loses nothing finished, and a re-run skips what is done.
"""

from __future__ import annotations

import csv
import inspect
import json
import math
import os
import statistics
import time
from collections.abc import Iterable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from voiopt import instance as instance_mod
from voiopt.errors import MissingExtraError, OptionError, VoioptError
from voiopt.instance import atomic_write, write_json_atomic
from voiopt.interrupt import progress_bar
from voiopt.models.mdp import check_reward_units
from voiopt.result import Result, load_result
from voiopt.simulate import check_objective, sense
from voiopt.solvers import METHODS, RANDOMISED, solver_function

GAP_COLUMNS = ["instance", "method", "seed", "objective", "status", "value", "bound", "best_value", "best_bound",
               "gap", "runtime_s"]


@dataclass(frozen=True)
class Task:
    """One (instance, method, seed) run and where its result goes; seed is None for a
    deterministic method."""

    instance_path: str
    instance_name: str
    method: str
    objective: str
    options: dict[str, Any] = field(default_factory=dict)
    out_path: str = ""
    seed: int | None = None


def expand_instances(paths: Iterable[str | os.PathLike]) -> list[Path]:
    """Instance files, and the ``*.json`` files of folders, in a stable order."""
    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found = sorted(p.glob("*.json"))
            if not found:
                raise OptionError(f"INSTANCES: folder {p} holds no .json files")
            out.extend(found)
        elif p.is_file():
            out.append(p)
        else:
            raise OptionError(f"INSTANCES: {p}: no such file or folder")
    if not out:
        raise OptionError("INSTANCES: no instance given")
    return out


def check_methods(methods: Sequence[str]) -> list[str]:
    if not methods:
        raise OptionError("--methods: give at least one method")
    for m in methods:
        if m not in METHODS:
            raise OptionError(f"--methods: unknown method {m!r} (choose from {', '.join(METHODS)})")
    if len(set(methods)) != len(methods):
        raise OptionError(f"--methods: a method is repeated in {','.join(methods)}")
    return list(methods)


def method_options(method: str, **given: Any) -> dict[str, Any]:
    """The options a method takes, from those given (None means 'not given')."""
    params = inspect.signature(solver_function(method)).parameters
    return {k: v for k, v in given.items() if v is not None and k in params}


def run_task(task: Task) -> dict[str, Any]:
    """Solve one pair and write its result; a failure becomes a result with status 'error'."""
    start = time.perf_counter()
    try:
        inst = instance_mod.load(task.instance_path)
        result = solver_function(task.method)(inst, task.objective, **task.options)
    except Exception as e:  # recorded, never fatal for the sweep
        result = Result(
            task.instance_name, task.method, task.objective, "error", None, None, None,
            time.perf_counter() - start, None, None, {"error": f"{type(e).__name__}: {e}"},
        )
    result.save(task.out_path)
    return {"instance": task.instance_name, "method": task.method, "status": result.status}


def is_done(path: str | os.PathLike) -> bool:
    """A finished pair: its result file exists and reads back (a torn file cannot exist)."""
    try:
        load_result(path)
        return True
    except (VoioptError, OSError):
        return False


@contextmanager
def make_executor(workers: int, dask_scheduler: str | None):
    """A process pool, or a Dask cluster's executor (an existing one, or 'local')."""
    if workers < 1:
        raise OptionError(f"--workers: must be >= 1, got {workers}")
    if dask_scheduler is None:
        with ProcessPoolExecutor(max_workers=workers) as ex:
            yield ex
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise MissingExtraError("distributed", "dask") from None
    if dask_scheduler == "local":
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    else:
        cluster = None
        try:
            client = Client(dask_scheduler, timeout="10s")
        except OSError as e:
            raise OptionError(f"--dask-scheduler: cannot reach {dask_scheduler}: {e}") from None
    try:
        yield client.get_executor()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_tasks(
    tasks: Sequence[Task], *, workers: int = 1, dask_scheduler: str | None = None,
    progress: bool = False, description: str = "pairs",
) -> int:
    """Run the tasks not yet done; return how many were run. Ctrl-C cancels what has not started."""
    todo = [t for t in tasks if not is_done(t.out_path)]
    bar = progress_bar(progress)
    with bar:
        job = bar.add_task(description, total=len(tasks), completed=len(tasks) - len(todo))
        if not todo:
            return 0
        if workers == 1 and dask_scheduler is None:
            for t in todo:  # in-process: simplest, and Ctrl-C reaches the solver itself
                run_task(t)
                bar.advance(job)
            return len(todo)
        with make_executor(workers, dask_scheduler) as ex:
            futures: list[Future] = [ex.submit(run_task, t) for t in todo]
            try:
                for f in as_completed(futures):
                    f.result()
                    bar.advance(job)
            except BaseException:  # Ctrl-C or a broken pool: drop what has not started
                for f in futures:
                    f.cancel()
                raise
    return len(todo)


def check_manifest(out_dir: Path, settings: dict[str, Any]) -> None:
    """Resume only a run made with the same settings: ``run.json`` records them.

    Without this, re-running into a folder with other options (episodes, time limit, seed,
    objective) would silently mix results of two different experiments."""
    path = out_dir / "run.json"
    settings = json.loads(json.dumps(settings))  # the form it has on disk
    if path.is_file():
        try:
            old = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            old = None
        if old != settings:
            diff = sorted(k for k in set(settings) | set(old or {}) if (old or {}).get(k) != settings.get(k))
            raise OptionError(
                f"-o/--out: {out_dir} holds a run with other settings ({', '.join(diff)} differ); "
                "use another folder, or delete it to start again"
            )
        return
    write_json_atomic(path, settings)


def result_path(folder: Path, instance_name: str, method: str, seed: int | None = None) -> Path:
    suffix = "" if seed is None else f"__seed{seed}"
    return folder / f"{instance_name}__{method}{suffix}.json"


def check_seeds(seeds: int) -> int:
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise OptionError(f"--seeds: must be an integer >= 1, got {seeds!r}")
    return seeds


def method_tasks(
    instance_path: Path, instance_name: str, methods: Sequence[str], objective: str, folder: Path,
    seed: int = 0, seeds: int = 1, **options: Any,
) -> list[Task]:
    """The runs of one instance: one per deterministic method, and one per seed
    seed .. seed + seeds - 1 for each randomised method (MODEL.md section 7)."""
    tasks = []
    for m in methods:
        run_seeds = [seed + k for k in range(seeds)] if m in RANDOMISED else [None]
        for s in run_seeds:
            opts = method_options(m, **options, seed=seed if s is None else s)
            tasks.append(Task(str(instance_path), instance_name, m, objective, opts,
                              str(result_path(folder, instance_name, m, s)), s))
    return tasks


def plan_tasks(
    instance_paths: Sequence[Path], methods: Sequence[str], objective: str, out_dir: Path,
    seed: int = 0, seeds: int = 1, **options: Any,
) -> list[Task]:
    names: dict[str, Path] = {}
    tasks = []
    for p in instance_paths:
        inst = instance_mod.load(p)  # validate up front: one clear error before any work
        if inst.name in names:
            raise OptionError(f"INSTANCES: {p} and {names[inst.name]} are both named {inst.name!r}")
        names[inst.name] = p
        tasks += method_tasks(p, inst.name, methods, objective, out_dir / "results", seed, seeds, **options)
    return tasks


def gap_rows(results: Sequence[Result], objective: str, seeds: Sequence[int | None] | None = None) -> list[dict[str, Any]]:
    """One row per result, with the best plan value and tightest proven bound of its instance
    (over every method and seed); ``seeds`` gives each result's seed (None: deterministic)."""
    seeds = list(seeds) if seeds is not None else [None] * len(results)
    maximise = sense(objective) == "max"
    best = max if maximise else min
    tight = min if maximise else max
    by_instance: dict[str, list[Result]] = {}
    for r in results:
        by_instance.setdefault(r.instance, []).append(r)
    rows = []
    for r, seed in zip(results, seeds, strict=True):
        group = by_instance[r.instance]
        values = [g.value for g in group if g.value is not None]
        bounds = [g.bound for g in group if g.bound is not None]
        best_value = best(values) if values else None
        best_bound = tight(bounds) if bounds else None
        gap = None
        if r.value is not None and best_bound is not None:
            diff = (best_bound - r.value) if maximise else (r.value - best_bound)
            gap = max(diff, 0.0) / max(abs(best_bound), 1e-300)
        rows.append({
            "instance": r.instance, "method": r.method, "seed": seed, "objective": r.objective, "status": r.status,
            "value": r.value, "bound": r.bound, "best_value": best_value, "best_bound": best_bound,
            "gap": gap, "runtime_s": r.runtime_s,
        })
    return rows


def write_csv(path: Path, rows: Sequence[dict[str, Any]], columns: Sequence[str], header: Sequence[str] = ()) -> None:
    """A CSV written atomically; ``header`` lines go first as '# ...' comments."""
    with atomic_write(path, newline="") as f:
        for line in header:
            f.write(f"# {line}\n")
        w = csv.DictWriter(f, fieldnames=list(columns))
        w.writeheader()
        for row in rows:
            w.writerow({k: ("" if row.get(k) is None else row[k]) for k in columns})


def read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, encoding="utf-8") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def summarise(rows: Sequence[dict[str, Any]], methods: Sequence[str]) -> list[dict[str, Any]]:
    """Per method: gaps over every run (seeds and networks), as mean, min, max and median."""
    out = []
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        gaps = [r["gap"] for r in mine if r["gap"] is not None]
        times = [r["runtime_s"] for r in mine if r["status"] != "error"]
        seeds = sorted({r["seed"] for r in mine if r.get("seed") is not None})
        out.append({
            "method": m,
            "instances": len({r["instance"] for r in mine}),
            "runs": len(mine),
            "seeds": seeds,
            "optimal": sum(r["status"] == "optimal" for r in mine),
            "errors": sum(r["status"] == "error" for r in mine),
            "median_gap": statistics.median(gaps) if gaps else None,
            "mean_gap": statistics.fmean(gaps) if gaps else None,
            "min_gap": min(gaps) if gaps else None,
            "max_gap": max(gaps) if gaps else None,
            "within_1pct": sum(g <= 0.01 for g in gaps),
            "median_runtime_s": statistics.median(times) if times else None,
        })
    return out


def _pct(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.3g} %"


def _seed_text(seeds: Sequence[int]) -> str:
    if not seeds:
        return "-"
    if seeds == list(range(seeds[0], seeds[-1] + 1)) and len(seeds) > 2:
        return f"{seeds[0]}-{seeds[-1]}"
    return ", ".join(map(str, seeds))


def summary_markdown(summary: Sequence[dict[str, Any]], objective: str, n_instances: int,
                     reward_units: str | None = None) -> str:
    lines = [
        f"# Gap report: {objective}",
        "",
        f"{n_instances} instance(s). The gap of a plan is its relative distance to the tightest "
        "proven bound over all methods for that instance (a proven optimality gap; exact when "
        "an exact method proved optimality). Every value is simulated from the plan. "
        "A randomised method runs once per seed; its mean, min and max gap are over every seed "
        "and network (one seed is an anecdote).",
    ]
    if reward_units is not None:
        lines.append(f"Q-learning reward reading: V in {reward_units}, idle penalty 100 (MODEL.md section 7).")
    lines += [
        "",
        "| method | instances | seeds | runs | optimal | errors | mean gap | min gap | max gap | median gap | within 1 % | median runtime |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for s in summary:
        rt = "-" if s["median_runtime_s"] is None else f"{s['median_runtime_s']:.3g} s"
        lines.append(
            f"| {s['method']} | {s['instances']} | {_seed_text(s['seeds'])} | {s['runs']} | {s['optimal']} | "
            f"{s['errors']} | {_pct(s['mean_gap'])} | {_pct(s['min_gap'])} | {_pct(s['max_gap'])} | "
            f"{_pct(s['median_gap'])} | {s['within_1pct']}/{s['runs']} | {rt} |"
        )
    lines += ["", "![gap distributions](gaps.png)", ""]
    return "\n".join(lines)


def plot_gaps(rows: Sequence[dict[str, Any]], methods: Sequence[str], path: Path, objective: str) -> None:
    from voiopt.figures import save_figure, start_figure

    fig, ax = start_figure(figsize=(1.6 + 1.3 * len(methods), 3.6))
    data = [[100 * r["gap"] for r in rows if r["method"] == m and r["gap"] is not None] for m in methods]
    positions = range(1, len(methods) + 1)
    ax.boxplot([d or [math.nan] for d in data], positions=list(positions), widths=0.5, showfliers=False)
    for x, d in zip(positions, data, strict=True):
        jitter = [x + 0.12 * ((k * 0.618) % 1 - 0.5) for k in range(len(d))]
        ax.scatter(jitter, d, s=10, alpha=0.6, color="tab:blue", zorder=3)
    ax.set_xticks(list(positions), methods, rotation=20)
    ax.set_ylabel("proven gap to optimum (%)")
    ax.set_title(f"{objective}: gap distributions")
    save_figure(fig, path)


def gap_report(
    instances: Sequence[str | os.PathLike],
    methods: Sequence[str],
    objective: str,
    out_dir: str | os.PathLike,
    *,
    time_limit: float | None = None,
    episodes: int | None = None,
    seed: int = 0,
    seeds: int = 3,
    reward_units: str = "bit/s",
    workers: int = 1,
    dask_scheduler: str | None = None,
    progress: bool = False,
) -> list[dict[str, Any]]:
    """Run every (instance, method, seed), then write gaps.csv, summary.md and gaps.png.
    Randomised methods run with seeds seed .. seed + seeds - 1; the others once."""
    check_objective(objective)
    methods = check_methods(methods)
    check_seeds(seeds)
    check_reward_units(reward_units)
    if time_limit is not None and not time_limit > 0:
        raise OptionError(f"--time-limit: must be > 0 seconds, got {time_limit:g}")
    out = Path(out_dir)
    paths = expand_instances(instances)
    options = dict(time_limit=time_limit, episodes=episodes, reward_units=reward_units, threads=1)
    check_manifest(out, {"command": "gap-report", "objective": objective, "seed": seed, "seeds": seeds, **options})
    tasks = plan_tasks(paths, methods, objective, out, seed=seed, seeds=seeds, **options)
    run_tasks(tasks, workers=workers, dask_scheduler=dask_scheduler, progress=progress, description="runs")
    results = [load_result(t.out_path) for t in tasks]
    rows = gap_rows(results, objective, [t.seed for t in tasks])
    write_csv(out / "gaps.csv", rows, GAP_COLUMNS)
    n_instances = len({t.instance_name for t in tasks})
    summary = summarise(rows, methods)
    uses_q = any(m in RANDOMISED for m in methods)
    md = summary_markdown(summary, objective, n_instances, reward_units if uses_q else None)
    with atomic_write(out / "summary.md") as f:
        f.write(md)
    plot_gaps(rows, methods, out / "gaps.png", objective)
    return rows
