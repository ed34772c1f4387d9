"""Many runs of (instance, method, seed) in a process pool or on Dask, resumable.

Each run's result is written to its own JSON file as soon as it finishes, so an interrupted
or crashed sweep loses nothing finished, and a re-run skips what is done. ``run.json``
records the settings of a folder so that two experiments are never mixed.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import os
import signal
import threading
import time
import warnings
from collections.abc import Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass, field
from itertools import islice
from pathlib import Path
from typing import Any

from voiopt.core import instance as instance_mod
from voiopt.core.instance import Instance
from voiopt.core.plan import made_for
from voiopt.core.result import Result, load_result
from voiopt.errors import (
    MissingExtraError,
    OptionError,
    VoioptError,
    WorkerDied,
    check_episodes,
    check_seed,
    check_stream_seeds,
    first_line,
)
from voiopt.mdp.robot import check_reward_units
from voiopt.runtime.files import atomic_write, loads_json, read_json, safe_name, write_json_atomic
from voiopt.runtime.progress import progress_bar
from voiopt.runtime.status import Status
from voiopt.runtime.stop import (
    INTERRUPTED,
    Interrupted,
    last_signal,
    pool_worker,
    signals_seen,
    watch,
)
from voiopt.solvers import METHODS, RANDOMISED, check_robots, options_class, solver_function
from voiopt.solvers.base import check_limits


@dataclass(frozen=True)
class Task:
    """One (instance, method, seed) run and where its result goes; seed is None for a
    deterministic method. The instance travels with the task; ``group`` names the setting it
    belongs to, for a line of progress when a whole group has finished."""

    instance_path: str
    instance_name: str
    method: str
    objective: str
    options: dict[str, Any] = field(default_factory=dict)
    out_path: str = ""
    seed: int | None = None
    instance: dict[str, Any] = field(default_factory=dict)
    group: str = ""


def load_instances(paths: Iterable[str | os.PathLike], notes: list[str] | None = None) -> list[tuple[Path, Instance]]:
    """The instances named, and those of the ``*.json`` files of folders, in a stable order,
    validated before any work. In a folder, a JSON file that is no instance (a plan, a result:
    an object without ``sensors``) is skipped, with a line in ``notes``; a file that tries to
    be one and breaks a rule is an error, as is any file named on its own."""
    paths = list(paths)
    out: list[tuple[Path, Instance]] = []
    names: dict[str, Path] = {}
    for given in map(Path, paths):
        if given.is_dir():
            found = sorted(given.glob("*.json"))
            if not found:
                raise OptionError(f"INSTANCES: folder {given} holds no .json files")
        elif given.is_file():
            found = [given]
        else:
            raise OptionError(f"INSTANCES: {given}: no such file or folder")
        for p in found:
            data = read_json(p)
            if given.is_dir() and not (isinstance(data, dict) and "sensors" in data):
                if notes is not None:
                    notes.append(f"skipped {p}: not an instance (no 'sensors' field)")
                continue
            inst = instance_mod.from_dict(data, source=str(p))
            if inst.name in names:
                raise OptionError(f"INSTANCES: {p} and {names[inst.name]} are both named {inst.name!r}")
            names[inst.name] = p
            out.append((p, inst))
    if not out:
        raise OptionError(f"INSTANCES: no instance among {', '.join(map(str, paths)) or 'nothing'} (an instance "
                          "JSON has a 'sensors' field)")
    return out


def count_option(value: int, flag: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise OptionError(f"{flag}: must be an integer >= 1, got {value!r}")
    return value


WORKERS_PER_CPU = 4  # more processes only share the CPUs, and each holds its own tables


def check_workers(workers: int, dask_scheduler: str | None = None) -> int:
    """--workers: 1 to WORKERS_PER_CPU per CPU of this machine, for its own processes (a process
    pool, or Dask's 'local' cluster): --workers 1000000 started thousands of processes and
    brought the machine to a load of 1000 (a probe, 2026-12-03)."""
    count_option(workers, "--workers")
    most = WORKERS_PER_CPU * (os.cpu_count() or 1)
    if workers > most and dask_scheduler in (None, "local"):
        raise OptionError(f"--workers: at most {most} on this machine ({WORKERS_PER_CPU} per CPU), got {workers}")
    return workers


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
    return count_option(seeds, "--seeds")


def _dask(module: str):
    """A module of the [dask] extra; a one-line message naming the extra when it is missing."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtraError("distributed", "dask") from None


def check_scheduler(dask_scheduler: str | None) -> None:
    """Before any work: the optional package is there, and the address is one (resolved, not
    yet connected to)."""
    if dask_scheduler is None:
        return
    resolve_address = _dask("distributed.comm").resolve_address
    if dask_scheduler != "local":
        try:
            with warnings.catch_warnings():  # a removed protocol warns over several lines, then fails
                warnings.simplefilter("ignore")
                resolve_address(dask_scheduler)
        except Exception as e:  # no such host (OSError), not an address (ValueError), a protocol not installed
            why = first_line(e, type(e).__name__, limit=None)
            raise OptionError(f"--dask-scheduler: {dask_scheduler!r} is no scheduler address "
                              f"(tcp://HOST:PORT or 'local'): {why}") from None


def run_options(*, time_limit: float | None, memory_limit: float, episodes: int | None, reward_units: str,
                seeds: int, workers: int, dask_scheduler: str | None = None, seed: int = 0) -> dict[str, Any]:
    """Check the options every sweep shares; return those each run receives (one thread each)."""
    check_seed(seed)
    check_seeds(seeds)
    check_stream_seeds(seed, seeds, "--seed")  # before any work, not as K runs ending in error
    if episodes is not None:
        check_episodes(episodes, "--episodes")
    check_reward_units(reward_units)
    check_limits(time_limit, memory_limit)
    check_workers(workers, dask_scheduler)
    check_scheduler(dask_scheduler)
    return dict(time_limit=time_limit, memory_limit=memory_limit, episodes=episodes, reward_units=reward_units,
                threads=1)


def method_options(method: str, **given: Any) -> dict[str, Any]:
    """The options a method takes, from those given (None means 'not given')."""
    return options_class(method).taken({k: v for k, v in given.items() if v is not None})


def result_path(folder: Path, instance_name: str, method: str, seed: int | None = None) -> Path:
    suffix = "" if seed is None else f"__seed{seed}"
    return folder / f"{safe_name(instance_name)}__{method}{suffix}.json"


def method_tasks(
    instance: Instance, instance_path: str | os.PathLike, methods: Sequence[str], objective: str, folder: Path,
    seed: int = 0, seeds: int = 1, group: str = "", only: dict[str, Sequence[str]] | None = None, **options: Any,
) -> list[Task]:
    """The runs of one instance: one per deterministic method, and one per seed
    seed .. seed + seeds - 1 for each randomised method (MODEL.md section 7). ``only`` keeps
    an option for some methods alone (``{"time_limit": ["dp"]}``)."""
    only = only or {}
    tasks = []
    data = instance.to_dict()
    for m in methods:
        run_seeds = [seed + k for k in range(seeds)] if m in RANDOMISED else [None]
        for s in run_seeds:
            mine = {k: v for k, v in options.items() if k not in only or m in only[k]}
            opts = method_options(m, **mine, seed=seed if s is None else s)
            tasks.append(Task(str(instance_path), instance.name, m, objective, opts,
                              str(result_path(folder, instance.name, m, s)), s, data, group))
    return tasks


def solve_task(task: Task) -> dict[str, Any]:
    """Solve one run and return its result as a dict (it travels back through a future, so
    a worker needs no shared filesystem: the instance comes in the task, the caller writes).
    A failure becomes a result with status 'error'."""
    start = time.perf_counter()
    try:
        inst = instance_mod.from_dict(task.instance, source=task.instance_path)
        check_robots(inst, task.method)
        result = solver_function(task.method)(inst, task.objective, **task.options)
    except Exception as e:  # recorded, never fatal for the sweep
        result = Result(
            task.instance_name, task.method, task.objective, Status.ERROR, None, None, None,
            time.perf_counter() - start, None, None, {"error": f"{type(e).__name__}: {e}"},
        )
    return result.to_dict()


def _store(task: Task, result: dict[str, Any]) -> bool:
    """Write a finished run's result; an interrupted one is not finished and is not stored
    (a resume runs it again). Returns whether it was stored."""
    if result["status"] == INTERRUPTED:
        return False
    write_json_atomic(task.out_path, result)
    return True


def is_done(path: str | os.PathLike) -> bool:
    """A finished run: its result file exists, reads back (a torn file cannot exist), and was
    not interrupted (older versions stored those)."""
    try:
        return load_result(path).status != INTERRUPTED
    except (VoioptError, OSError):
        return False


SCHEDULER_WAIT_S = 15.0  # the Dask client's own connect timeout (10 s) does not cover its handshake


def _client(Client, address: str):
    """A Dask client of the scheduler at address, or a one-line OptionError. The client is made
    in a thread of its own, waited for SCHEDULER_WAIT_S: where a service that is not Dask waits
    for the client to speak first (an HTTP server), the client's handshake waits without end
    (found by a probe, 2026-12-03). The thread is left behind; the command ends."""
    box: dict[str, Any] = {}

    def make() -> None:
        try:
            box["client"] = Client(address, timeout="10s")
        except BaseException as e:  # noqa: BLE001 -- reported below, in the caller's thread
            box["error"] = e

    maker = threading.Thread(target=make, name="voiopt-dask-connect", daemon=True)
    seen, deadline = signals_seen(), time.monotonic() + SCHEDULER_WAIT_S
    maker.start()
    while maker.is_alive() and time.monotonic() < deadline and signals_seen() == seen:
        maker.join(0.1)
    e = box.get("error")
    if "client" in box:
        return box["client"]
    if signals_seen() != seen:  # Ctrl-C or SIGTERM while waiting: the sweep stops as a whole
        raise Interrupted(last_signal())
    if maker.is_alive():
        raise OptionError(f"--dask-scheduler: {address} did not answer as a Dask scheduler within "
                          f"{SCHEDULER_WAIT_S:g} s (is it a Dask scheduler's address?)")
    if isinstance(e, (OSError, ValueError)):  # unreachable, or not an address (ValueError)
        raise OptionError(f"--dask-scheduler: cannot reach {address}: {e}") from None
    # a service that is not Dask (ssh: a frame "length" of exabytes, MemoryError)
    raise OptionError(f"--dask-scheduler: {address} did not answer as a Dask scheduler: "
                      f"{first_line(e, type(e).__name__)}") from None


@contextmanager
def make_executor(workers: int, dask_scheduler: str | None):
    """A process pool, or a Dask cluster's executor (an existing one, or 'local')."""
    check_workers(workers, dask_scheduler)
    if dask_scheduler is None:
        with ProcessPoolExecutor(max_workers=workers, initializer=pool_worker, initargs=(os.getpid(),)) as ex:
            yield ex
        return
    distributed = _dask("distributed")
    Client, LocalCluster = distributed.Client, distributed.LocalCluster
    if dask_scheduler == "local":
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    else:
        cluster = None
        client = _client(Client, dask_scheduler)
    try:
        yield client.get_executor()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


FINGERPRINTS = "instances.sha256"  # in each results folder: "<sha256>  <file stem of the instance's name>" lines


def fingerprint(instance: dict[str, Any]) -> str:
    """A hash of an instance's content (its canonical dict), to tell a changed instance from
    the one a stored result was made from."""
    return hashlib.sha256(json.dumps(instance, sort_keys=True).encode("utf-8", "surrogatepass")).hexdigest()


def _read_fingerprints(path: Path) -> dict[str, str]:
    try:
        lines = path.read_text(encoding="utf-8").splitlines() if path.is_file() else []
    except (OSError, ValueError):
        return {}
    return {line[66:]: line[:64] for line in lines if len(line) > 66 and line[64:66] == "  "}


def _made_for(path: Path) -> str | None:
    """The ``instance`` a stored result names (None: not a result)."""
    try:
        return made_for(read_json(path))
    except (VoioptError, OSError):
        return None


def forget_changed(tasks: Sequence[Task], notes: list[str] | None = None) -> list[str]:
    """A stored result is done only for the instance it was made from. Each results folder's
    ``instances.sha256`` records the fingerprint of every instance run into it (by the file
    stem of its name, ``safe_name``); where an instance of the same name has changed since,
    every result in the folder made for it is deleted, of any method or seed (the sweep runs
    what it needs again), and a line goes to ``notes``. Returns the changed names. The
    deletions come before the new fingerprints are written, so a crash between the two cannot
    leave a stale result that counts as done."""
    folders: dict[Path, list[Task]] = {}
    for t in tasks:
        folders.setdefault(Path(t.out_path).parent, []).append(t)
    changed_all: list[str] = []
    for folder, mine in folders.items():
        path = folder / FINGERPRINTS
        old = _read_fingerprints(path)
        new = {safe_name(t.instance_name): fingerprint(t.instance) for t in mine}
        names = {safe_name(t.instance_name): t.instance_name for t in mine}
        changed = sorted(names[stem] for stem, f in new.items() if stem in old and old[stem] != f)
        if changed:
            for p in folder.glob("*.json"):
                if _made_for(p) in changed:
                    p.unlink(missing_ok=True)
            if notes is not None:
                notes.append(f"ran again: {', '.join(changed)} (changed since their results in {folder} were stored)")
        if any(old.get(stem) != f for stem, f in new.items()):
            with atomic_write(path) as f:
                f.writelines(f"{h}  {stem}\n" for stem, h in sorted({**old, **new}.items()))
        changed_all += changed
    return changed_all


def run_tasks(
    tasks: Sequence[Task], *, workers: int = 1, dask_scheduler: str | None = None,
    progress: bool = False, description: str = "runs", notes: list[str] | None = None,
) -> int:
    """Run the tasks not yet done (``forget_changed``: a result stored for another instance of
    the same name is not done); return how many were run. Each finished result is written
    at once. Ctrl-C or SIGTERM stops the whole sweep: what has not started is cancelled,
    running solves stop with their best plan (not stored), and Interrupted is raised."""
    forget_changed(tasks, notes)
    todo = [t for t in tasks if not is_done(t.out_path)]
    groups = _group_sizes(tasks)
    left = {g: sum(1 for t in todo if t.group == g) for g in groups}
    bar = progress_bar(progress)
    with watch() as stop, bar:
        job = bar.add_task(description, total=len(tasks), completed=len(tasks) - len(todo))

        def finished(task: Task, result: dict[str, Any]) -> None:
            if _store(task, result):
                bar.advance(job)
                left[task.group] -= 1
                if progress and task.group and not left[task.group]:
                    bar.console.print(f"finished: {task.group} ({groups[task.group]} runs)", markup=False)

        if workers == 1 and dask_scheduler is None:
            for t in todo:  # in-process: the solver sees the signal itself and stops
                if stop.requested:
                    break
                finished(t, solve_task(t))
        elif todo:
            with make_executor(min(workers, len(todo)), dask_scheduler) as ex:
                # a process pool gets one run per worker at a time: runs queued in the pool
                # cannot be cancelled, so a stop waited out STOP_GRACE_S while they started,
                # and SIGKILLed workers left the pool's queue feeder blocked for ever
                # (a probe, 2026-12-03). A Dask cluster gets them all, and cancels.
                queue = iter(todo)
                pending = {ex.submit(solve_task, t): t
                           for t in islice(queue, len(todo) if dask_scheduler else min(workers, len(todo)))}
                try:
                    while pending and not stop.requested:
                        done, _ = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                        for f in done:
                            finished(pending.pop(f), f.result())
                            for t in islice(queue, 0 if stop.requested else 1):
                                pending[ex.submit(solve_task, t)] = t
                    if stop.requested:  # running solves hand back their best plan (not stored) or are ended
                        for f in pending:
                            f.cancel()
                        _signal_workers(ex, signal.SIGTERM)
                        for f in wait(pending, timeout=STOP_GRACE_S).done:
                            if not f.cancelled() and f.exception() is None:
                                finished(pending[f], f.result())
                except BrokenProcessPool:
                    raise WorkerDied(
                        "a worker process died (killed, or out of memory?); finished results are kept "
                        "and a re-run resumes"
                    ) from None
                finally:
                    for f in pending:
                        f.cancel()
                    _signal_workers(ex, signal.SIGKILL)  # nothing left to wait for: no hanging at shutdown
    if stop.requested:
        raise Interrupted(stop.signal)
    return len(todo)


STOP_GRACE_S = 5.0  # how long a stopped sweep waits for its running solves to hand back


def _signal_workers(ex, signum: int) -> None:
    """Signal the pool's worker processes: SIGTERM passes a stop request on (a terminal's Ctrl-C
    reaches them anyway; a SIGTERM sent to this process alone does not); SIGKILL ends them
    when the sweep ends, so that leaving the pool never waits on a long solve. (Dask workers
    are not this process's children: their runs end on the cluster's side.)"""
    for proc in list((getattr(ex, "_processes", None) or {}).values()):
        try:
            os.kill(proc.pid, signum)
        except (OSError, AttributeError):
            pass


def _group_sizes(tasks: Sequence[Task]) -> dict[str, int]:
    sizes: dict[str, int] = {}
    for t in tasks:
        sizes[t.group] = sizes.get(t.group, 0) + 1
    return sizes


@contextmanager
def freed_unless_stored(out_dir: Path, created: bool):
    """Around the block that runs a sweep: the ``run.json`` that ``check_manifest`` wrote
    (``created``) is removed again if the block fails before any result is stored in
    ``out_dir / "results"``, so that a run that could not start (a Dask scheduler out of reach)
    does not hold the folder to its settings."""
    try:
        yield
    except BaseException:
        if created and not any((out_dir / "results").rglob("*.json")):
            (out_dir / "run.json").unlink(missing_ok=True)
        raise


def check_manifest(out_dir: Path, settings: dict[str, Any], what: str = "-o/--output") -> bool:
    """Resume only a run made with the same settings: ``run.json`` records them. Returns
    whether it wrote ``run.json`` (a new run).

    Without this, re-running into a folder with other options (episodes, time limit, seed,
    objective) would silently mix results of two different experiments."""
    path = out_dir / "run.json"
    settings = json.loads(json.dumps(settings))  # the form it has on disk
    if path.is_file():
        try:
            old = loads_json(path.read_text(encoding="utf-8"))
        except (OSError, ValueError, VoioptError):
            old = None
        if not isinstance(old, dict):
            raise OptionError(f"{what}: {out_dir} holds a run.json that is not a voiopt run's settings; "
                              "use another folder, or delete it to start again")
        if old != settings:
            diff = sorted(k for k in set(settings) | set(old) if old.get(k) != settings.get(k))
            raise OptionError(
                f"{what}: {out_dir} holds a run with other settings ({', '.join(diff)} "
                f"{'differs' if len(diff) == 1 else 'differ'}); "
                "use another folder, or delete it to start again"
            )
        return False
    write_json_atomic(path, settings)
    return True
