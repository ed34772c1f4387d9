"""Many runs of (instance, method, seed) in a process pool or on Dask, resumable.

Each run's result is written to its own JSON file as soon as it finishes, so an interrupted
or crashed sweep loses nothing finished, and a re-run skips what is done. ``run.json``
records the settings of a folder so that two experiments are never mixed.
"""

from __future__ import annotations

import inspect
import json
import os
import time
from collections.abc import Iterable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from voiopt import instance as instance_mod
from voiopt._files import write_json_atomic
from voiopt.errors import MissingExtraError, OptionError, VoioptError
from voiopt.progress import progress_bar
from voiopt.result import Result, load_result
from voiopt.solvers import METHODS, RANDOMISED, solver_function


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


def check_seeds(seeds: int) -> int:
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise OptionError(f"--seeds: must be an integer >= 1, got {seeds!r}")
    return seeds


def method_options(method: str, **given: Any) -> dict[str, Any]:
    """The options a method takes, from those given (None means 'not given')."""
    params = inspect.signature(solver_function(method)).parameters
    return {k: v for k, v in given.items() if v is not None and k in params}


def result_path(folder: Path, instance_name: str, method: str, seed: int | None = None) -> Path:
    suffix = "" if seed is None else f"__seed{seed}"
    return folder / f"{instance_name}__{method}{suffix}.json"


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
