"""VoI-Lib: frozen, versioned benchmark instances with certificates, and scoring against them.

The instances ship as package data (``voiopt/data/voilib/instances``) and never change within
a version. ``certificates.json`` holds, per instance and objective, the best plan known, its
simulated value, a proven bound, the status ("optimal" when they meet, else "bounded": the
optimum lies between value and bound), the methods that found the plan and proved the bound,
the voiopt version and the instance's sha256. dp and the MILP certify every entry
independently; where both prove optimality their values must agree, or certification fails.
``certify`` writes certificates into a folder the user names; ``voilib_certificates.merge`` is the
only writer of the shipped ones, and never weakens a certificate (docs/voilib.md).
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
from importlib import resources
from pathlib import Path
from typing import Any

from voiopt import objectives
from voiopt.core import instance as instance_mod
from voiopt.core.instance import Instance, show
from voiopt.core.links import is_lossy
from voiopt.core.plan import Plan
from voiopt.core.result import Result, agrees, finite
from voiopt.core.simulate import simulate
from voiopt.errors import OptionError, PlanError, VoioptError, first_line
from voiopt.networks.generate import case_study, generate_set, write_set
from voiopt.objectives import OBJECTIVES, best, better, gap, tightest
from voiopt.runtime.files import (
    atomic_write,
    check_output_dir,
    check_output_file,
    loads_json,
    read_json,
    safe_name,
    write_json_atomic,
)
from voiopt.runtime.progress import progress_bar
from voiopt.runtime.status import Status
from voiopt.voilib import export as voilib_export
from voiopt.voilib import lossy, lossy_score
from voiopt.voilib.certificates import instance_hash, make_provenance, provenance, same, today
from voiopt.voilib.lossy_score import ClaimError

VERSION = "1.3"  # a certificate changes only with a new version of the library (1.1: the cover bound; 1.2: two
# threads; 1.3: the lossy set, voilib.lossy.LOSSY_LADDER)
DATA = resources.files("voiopt") / "data" / "voilib"
CERTIFYING_METHODS = ("dp", "milp")

# The ladder of version 1: (group, count, what generates it). Names are group-k.
LADDER: list[tuple[str, int, dict[str, Any]]] = [
    ("paper-n3-t10", 2, dict(n_sensors=3, horizon=10)),
    ("paper-n4-t20", 2, dict(n_sensors=4, horizon=20)),
    ("paper-n4-t30", 4, dict(n_sensors=4, horizon=30)),
    ("paper-n5-t30", 2, dict(n_sensors=5, horizon=30)),
    ("paper-n6-t30", 2, dict(n_sensors=6, horizon=30)),
    ("paper-n8-t30", 2, dict(n_sensors=8, horizon=30)),
    ("long-n4-t50", 2, dict(n_sensors=4, horizon=50, width=10.0, height=10.0)),
    ("long-n4-t100", 2, dict(n_sensors=4, horizon=100, width=10.0, height=10.0)),
    ("grid15-n5-t40", 2, dict(n_sensors=5, horizon=40, width=15.0, height=15.0)),
    ("walls-n4-t30", 3, dict(n_sensors=4, horizon=30, blocked_fraction=0.2, end="start", max_moves=20)),
    ("factory-n4-t30", 2, dict(preset="factory", n_sensors=4, horizon=30, max_moves=24)),
    ("factory-n6-t60", 2, dict(preset="factory", n_sensors=6, horizon=60, max_moves=48)),
    ("factory-n12-t100", 2, dict(preset="factory", n_sensors=12, horizon=100, max_moves=80)),
]
LADDER_SEED = 2027


def _version() -> str:
    """The installed voiopt's version (the package metadata, as pip sees it)."""
    from importlib.metadata import version

    return version("voiopt")


def ladder() -> list[Instance]:
    """The instances of this version, drawn afresh (the frozen files are these, and
    tests/test_voilib.py checks it): the case study, each group of LADDER, then the lossy set."""
    out = [case_study()]
    for k, (group, count, spec) in enumerate(LADDER):
        spec = dict(spec)
        if spec.pop("preset", None) == "factory":
            nets = generate_set(count, seed=LADDER_SEED + k, preset="factory", name=group, **spec)
        else:
            nets = generate_set(count, seed=LADDER_SEED + k, name=group, **spec)
        out += nets
    return out + lossy.lossy_ladder({inst.name: inst for inst in out})


def instances() -> dict[str, Instance]:
    """The frozen instances, by name, in file order."""
    folder = DATA / "instances"
    out = {}
    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
        if entry.name.endswith(".json"):
            inst = instance_mod.from_dict(loads_json(entry.read_text("utf-8")), source=entry.name)
            out[inst.name] = inst
    return out


_CACHE: dict[str, Any] = {}


def certificates() -> dict[str, Any]:
    """The shipped certificates.json ({} entries if none have been made); read once per
    version of the file (an env asks at every episode)."""
    entry = DATA / "certificates.json"
    if not entry.is_file():
        return {"version": VERSION, "instances": {}}
    text = entry.read_text("utf-8")
    key = hashlib.sha256(text.encode("utf-8")).hexdigest()
    if _CACHE.get("key") != key:
        _CACHE.update(key=key, data=loads_json(text))
    return _CACHE["data"]


def certificate(inst: Instance, objective: str) -> dict[str, Any] | None:
    """A VoI-Lib instance's certificate for ``objective`` (matched by hash), or None if the
    instance is not in the library."""
    digest = instance_hash(inst)
    for entry in certificates()["instances"].values():
        if entry["sha256"] == digest:
            return entry["certificates"].get(objective)
    return None


def certified(inst: Instance, objective: str) -> float | None:
    """The proven optimum of a VoI-Lib instance, or None if the instance is not in the library
    or its certificate is still an interval."""
    cert = certificate(inst, objective)
    return cert["value"] if cert is not None and cert["status"] == "optimal" else None


def open_certificate(inst: Instance, objective: str) -> str | None:
    """The interval of a VoI-Lib instance's open certificate (None if the instance is not in
    the library, or its certificate is optimal)."""
    cert = certificate(inst, objective)
    return show_certificate(cert) if cert is not None and cert["status"] != "optimal" else None


def freeze(out_dir: str | os.PathLike) -> list[Path]:
    """Write the ladder's instances to ``out_dir`` (a maintainer's step for a new version)."""
    return write_set(ladder(), out_dir)


# ------------------------------------------------------------------------- the table


def describe(inst: Instance) -> dict[str, Any]:
    """Sizes and rules of an instance, for the table."""
    rules = [r for r, on in (("blocked", inst.blocked), ("end", inst.end is not None),
                             ("max_moves", inst.max_moves is not None)) if on]
    return {"name": inst.name, "N": inst.n_sensors, "T": inst.horizon,
            "area": f"{inst.width:g}x{inst.height:g}", "rules": ",".join(rules) or "-", "links": lossy.links_text(inst)}


LIST_COLUMNS = voilib_export.COLUMNS  # bench list's and the README's


def show_certificate(cert: dict[str, Any] | None) -> str:
    """A certificate as the table shows it: the optimum, or [value, bound] when open."""
    if cert is None:
        return "-"
    if cert["status"] == "optimal":
        return f"{cert['value']:.6g}{lossy.label(cert)}"
    lo, hi = sorted((cert["value"], cert["bound"]))
    digits = 6  # as many as it takes to tell an open interval from a point
    while digits < 17 and f"{lo:.{digits}g}" == f"{hi:.{digits}g}" and lo != hi:
        digits += 1
    return f"[{lo:.{digits}g}, {hi:.{digits}g}]{lossy.label(cert)}"


def table_rows() -> list[dict[str, Any]]:
    certs = certificates()["instances"]
    rows = []
    for name, inst in instances().items():
        row = describe(inst)
        entry = certs.get(name, {}).get("certificates", {})
        for objective in OBJECTIVES:
            row[objective] = show_certificate(entry.get(objective))
        rows.append(row)
    return rows


def export(out_dir: str | os.PathLike, overwrite: bool = False) -> Path:
    """The instances, certificates.json (each certificate with its provenance), a README (the
    certified values, the formats, how to score) and ``solutions/``, one submission per instance
    and objective, into ``out_dir`` (created). A file there that holds another instance under a
    library instance's name (a copy someone edited) is not replaced unless ``overwrite``:
    nothing is written then."""
    out = check_output_dir(out_dir, "--out", parents=True)
    lib = list(instances().values())
    certs = certificates()
    solutions = {voilib_export.solution_name(safe_name(name), objective):
                 voilib_export.solution(name, objective, entry["sha256"], cert)
                 for name, entry in certs["instances"].items() for objective, cert in entry["certificates"].items()}
    if out.is_dir():  # before writing any: no file to write is a folder there
        for name in [*(f"{safe_name(inst.name)}.json" for inst in lib), "certificates.json", "README.md"]:
            check_output_file(out / name, "--out")
        if (out / "solutions").is_dir():
            for name in solutions:
                check_output_file(out / "solutions" / name, "--out")
    write_set(lib, out, overwrite=overwrite)
    with_provenance = {**certs, "instances": {
        name: {**entry, "certificates": {o: {**c, "provenance": provenance(c)} for o, c in entry["certificates"].items()}}
        for name, entry in certs["instances"].items()}}
    write_json_atomic(out / "certificates.json", with_provenance)
    lossy.copy_policies(certs["instances"], Path(str(DATA)), out)  # the lossy set's optimal policies
    (out / "solutions").mkdir(exist_ok=True)
    for name, doc in solutions.items():
        write_json_atomic(out / "solutions" / name, doc)
    with atomic_write(out / "README.md") as f:
        f.write(voilib_export.readme(VERSION, table_rows()))
    return out


# ------------------------------------------------------------------------- scoring


def find_instance(result: dict[str, Any]) -> tuple[str, Instance]:
    """The VoI-Lib instance a result names, by ``instance_sha256`` if given, else by name."""
    lib = instances()
    digest = result.get("instance_sha256")
    if digest is not None:
        for name, inst in lib.items():
            if isinstance(digest, str) and instance_hash(inst) == digest.lower():  # hex in either case
                named = result.get("instance")
                if named is not None and named != name:  # two names for the instance: neither wins unsaid
                    raise OptionError(f"instance: {show(named)} is not the instance its instance_sha256 names "
                                      f"({name}); give one, or both of the same instance")
                return name, inst
        raise OptionError(f"instance_sha256: {show(digest, 70)} is no VoI-Lib {VERSION} instance")  # 64 digits whole
    if "instance" not in result:
        raise OptionError("instance: is required (a VoI-Lib instance's name), or instance_sha256")
    name = result.get("instance")
    if not isinstance(name, str) or name not in lib:
        raise OptionError(f"instance: {show(name)} is no VoI-Lib {VERSION} instance (see voiopt bench list)")
    return name, lib[name]


def score(result: dict[str, Any], source: str | None = None) -> dict[str, Any]:
    """Re-simulate a submitted result (``instance``, ``objective``, ``plan``, optional
    ``value``) against its VoI-Lib instance; its gap to the certificate, and the certificate's
    status, value and bound as numbers (``certified`` is its text). A stated value its plan
    does not give, or an illegal plan, raises with one line, naming ``source`` (a file)."""
    row_source, source = source, source or "result"
    if not isinstance(result, dict):
        raise OptionError(f"{source}: must be a result object with instance, objective and plan")
    if "sensors" in result or "instances" in result:
        what = "an instance" if "sensors" in result else "a certificates file"
        raise OptionError(f"{source}: {what}, not a result (instance, objective and plan; voiopt solve -o writes one)")
    _check_spelling(result, source)
    name, inst = find_instance(result)
    objective = result.get("objective")
    if objective is None:
        raise OptionError(f"{source}: objective: is required (one of {', '.join(OBJECTIVES)})")
    if not isinstance(objective, str) or objective not in OBJECTIVES:
        raise OptionError(f"{source}: objective: must be one of {', '.join(OBJECTIVES)}, got {show(objective)}")
    lossy_links = is_lossy(inst)
    if "plan" not in result and not lossy_links:
        raise OptionError(f"{source}: plan: is required")
    stated = result.get("value")
    if stated is not None and (isinstance(stated, bool) or not isinstance(stated, (int, float))
                               or not finite(stated)):
        raise OptionError(f"{source}: value: must be a finite number (or null, or absent), got {show(stated)}")
    cert = certificates()["instances"].get(name, {}).get("certificates", {}).get(objective)
    labels = dict.fromkeys(("evaluation", "samples", "value_ci", "bound_kind", "scored"))
    if lossy_links:  # a plan's exact expectation, or a policy's value (lossy_score)
        folder = Path(row_source).parent if row_source else Path(".")
        labels = lossy_score.measure(result, source, folder, name, inst, objective, stated)
        labels["bound_kind"] = None if cert is None else cert.get("bound_kind")
        return _row(row_source, name, objective, labels.pop("value"), result.get("status"), cert, labels)
    try:
        metrics = simulate(inst, Plan.from_dict({"plan": result["plan"]})).metrics  # errors name plan.
    except PlanError as e:  # the instance it was checked against, which a plan of another one would not fit
        raise PlanError(f"{e} (checked against VoI-Lib's {name})") from None
    value = metrics[objective]
    if stated is not None:
        if not agrees(stated, value):
            other = [o for o in OBJECTIVES if o != objective and agrees(stated, metrics[o])]
            if other:
                why = f"; it is the plan's {other[0]}: is objective right?"
            elif result.get("instance_sha256") is None:
                why = ("; was it solved on another instance of that name? (instance_sha256, from certificates.json, "
                       "names the instance exactly)")
            else:
                why = ""
            raise ClaimError(f"{source}: value: {stated!r} is not what its plan gives on VoI-Lib's {name} "
                              f"({value!r} by the simulator): rejected{why}")
    return _row(row_source, name, objective, value, result.get("status"), cert, labels)


def _row(source: str | None, name: str, objective: str, value: float, status: Any, cert: dict | None,
         labels: dict[str, Any]) -> dict[str, Any]:
    """A score's row: the value, the result's own status (an interrupted run's plan is scored,
    and says so), the certificate as numbers and text, the gaps, and the lossy labels."""
    row = {"result": source, "instance": name, "objective": objective, "value": value,
           "status": status if isinstance(status, str) else None,
           "certified": show_certificate(cert), "certified_status": None, "certified_value": None,
           "certified_bound": None, "gap_to_bound": None, "gap_to_best": None, **labels}
    if cert is not None:
        row.update(certified_status=cert["status"], certified_value=cert["value"], certified_bound=cert["bound"],
                   gap_to_bound=gap(value, cert["bound"]), gap_to_best=behind(objective, value, cert["value"]))
    return row


class UnreadableError(OptionError):
    """A submission file that cannot be read as JSON (``bench check``: exit 5)."""


SUBMISSION_FIELDS = ("instance", "instance_sha256", "objective", "plan", "value")
RESULT_FIELDS = ("method", "status", "bound", "gap", "runtime_s", "metrics", "solver")


def _check_spelling(result: dict[str, Any], source: str) -> None:
    """Other fields are a submitter's own (a method's name, a seed, ``instance_name``), but one
    spelled like a field bench score reads, one edit from it and not containing it, is a typo
    that would switch off what it asks ("vaule": the check of the stated value)."""
    for key in result:
        if key in SUBMISSION_FIELDS + RESULT_FIELDS or not isinstance(key, str):
            continue
        for known in SUBMISSION_FIELDS:
            if key.lower() == known or (known not in key.lower() and _edits(key.lower(), known) <= 1):
                raise OptionError(f"{source}: {show(key)}: unknown field; did you mean {known}?")


def _edits(a: str, b: str) -> int:
    """Damerau-Levenshtein distance (adjacent swaps count one): "vaule" is one from "value"."""
    d = [[i + j if i * j == 0 else 0 for j in range(len(b) + 1)] for i in range(len(a) + 1)]
    for i in range(1, len(a) + 1):
        for j in range(1, len(b) + 1):
            d[i][j] = min(d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] != b[j - 1]))
            if i > 1 and j > 1 and a[i - 1] == b[j - 2] and a[i - 2] == b[j - 1]:
                d[i][j] = min(d[i][j], d[i - 2][j - 2] + 1)
    return d[len(a)][len(b)]


def behind(objective: str, value: float, best_known: float) -> float:
    """How far ``value`` is behind the best known value, relative to it (the gap formula of
    MODEL.md section 6 with a sign): negative when it is better, a new best known plan."""
    g = gap(value, best_known)
    return -g if better(objective, value, best_known) else g


def bare(plan: Any, name: str, objective: str) -> dict[str, Any]:
    """A bare plan (``positions`` and ``schedule``, or a document with a ``plan``, such as a
    result of another instance's name) as a submission for VoI-Lib's ``name`` and ``objective``."""
    if isinstance(plan, dict) and "plan" in plan:
        plan = plan["plan"]
    return {"instance": name, "objective": objective, "plan": plan}


def score_files(paths: list[str], instance: str | None = None,
                objective: str | None = None) -> tuple[list[dict[str, Any]], list[VoioptError]]:
    """Score each file: (rows of the files scored, the error of each file rejected, naming the
    file). One bad file among many does not stop the others being scored. With ``instance``
    (a VoI-Lib name) and ``objective``, each file is a bare plan (``bare``)."""
    if (instance is None) != (objective is None):
        raise OptionError("--instance and --objective: give both (the files are bare plans), or neither")
    rows, errors = [], []
    for p in paths:
        try:
            doc = read_json(p, UnreadableError)
            rows.append(score(doc if instance is None else bare(doc, instance, objective), str(p)))
        except VoioptError as e:
            message = str(e)
            errors.append(type(e)(message if message.startswith(f"{p}: ") else f"{p}: {message}"))
    return rows, errors


# ------------------------------------------------------------------------- certification


def certificate_of(inst: Instance, objective: str, results: list[Result]) -> dict[str, Any]:
    """One certificate from the certifying runs of an instance and objective: the best
    simulated plan and the tightest proven bound. Two proofs of optimality must agree."""
    objective = objectives.get(objective)
    proved = [r for r in results if r.status == Status.OPTIMAL]
    for a in proved:
        for b in proved:
            if not same(a.value, b.value):
                raise VoioptError(f"certify: {inst.name} {objective}: {a.method} proves {a.value!r} and {b.method} "
                                  f"proves {b.value!r}: the exact methods disagree")
    with_plan = [r for r in results if r.plan is not None and r.value is not None]
    if not with_plan:  # each run's own words: a memory limit, say, said only in the --work files before
        why = "; ".join(f"{r.method}: {r.status}" + (f" ({first_line(r.solver.get('error') or r.solver.get('stopped'))})"
                                                    if r.solver.get("error") or r.solver.get("stopped") else "")
                        for r in results)
        raise VoioptError(f"certify: {inst.name} {objective}: no method returned a plan ({why or 'no runs'})")
    value = best(objective, [r.value for r in with_plan])
    top = next(r for r in with_plan if r.value == value)
    bounds = [r.bound for r in results if r.bound is not None]
    if proved:
        bound, bound_method = value, proved[0].method  # the plan's own value is the tightest proof
    elif bounds:
        bound = tightest(objective, bounds)
        bound_method = next(r.method for r in results if r.bound == bound)
    else:
        bound, bound_method = None, None
    status = "optimal" if proved else "bounded"  # a gap within tolerance is not a proof: bound == value
    cert = {
        "objective": objective, "status": status, "value": value, "bound": bound, "gap": gap(value, bound),
        "plan": top.plan.to_dict(), "method": top.method, "bound_method": bound_method,
        "checks": {r.method: {"status": r.status, "value": r.value, "bound": r.bound, "runtime_s": r.runtime_s}
                   for r in results},
        "voiopt_version": _version(), "instance_sha256": instance_hash(inst),
    }
    return {**cert, "provenance": make_provenance(cert, today())}


def certify(work_dir: str | os.PathLike, *, time_limit: float = 60.0, memory_limit: float | None = None,
            workers: int = 1, dask_scheduler: str | None = None, progress: bool = False,
            into: str | os.PathLike | None = None, only: list[str] | None = None, threads: int = 1) -> Path:
    """Run dp and the MILP on every instance (or those named in ``only``) and objective
    (results kept in ``work_dir``, so an interrupted run resumes, on a process pool or Dask;
    a ``work_dir`` made with another time limit, memory limit or threads is refused)
    and write certificates.json into ``into`` (default: ``work_dir``; never the package's own
    VoI-Lib folder unless named: ``voilib_certificates.merge`` is the step that updates the shipped
    certificates, refusing to weaken them). With ``only``, the other instances' entries of an existing
    certificates.json there are kept (those whose instance is unchanged). ``threads`` is each
    run's: dp's chunks expanded at once and the MILP's HiGHS threads (``workers`` times
    ``threads`` cores in all)."""
    from voiopt.core.result import load_result
    from voiopt.experiments.runner import (
        check_manifest,
        check_scheduler,
        check_workers,
        method_tasks,
        run_tasks,
    )
    from voiopt.solvers.base import check_limits, check_threads

    check_limits(time_limit, memory_limit)  # before any run: a bad limit would fail every one of them
    check_threads(threads)
    check_workers(workers, dask_scheduler)
    check_scheduler(dask_scheduler)
    every = lib = instances()
    if only is not None:
        unknown = [n for n in only if n not in every]
        if unknown:
            raise OptionError(f"--only: {unknown[0]!r} is no VoI-Lib {VERSION} instance")
        lib = {n: every[n] for n in only}
    work = check_output_dir(work_dir, "--work", parents=True)
    target = check_output_dir(into if into is not None else work_dir, "--into", parents=True)
    if target.is_dir():  # certificates.json can be written there (the package's own folder may be read-only)
        check_output_file(target / "certificates.json", "--into")
    work.mkdir(parents=True, exist_ok=True)
    check_manifest(work, {"command": "bench certify", "version": VERSION, "time_limit": time_limit,
                          "memory_limit": memory_limit, "threads": threads}, "--work")  # resume only the same runs
    tasks, plan = [], []
    lossy_lib = {n: i for n, i in lib.items() if is_lossy(i)}  # certified by lossy.certify_instance
    for name, inst in lib.items():
        for objective in OBJECTIVES if name not in lossy_lib else ():
            ts = method_tasks(inst, f"voilib:{name}", CERTIFYING_METHODS, objective, work, group=name,
                              time_limit=time_limit, memory_limit=memory_limit, threads=threads)
            ts = [dataclasses.replace(t, out_path=str(work / f"{safe_name(name)}__{objective}__{t.method}.json"))
                  for t in ts]  # one file per (instance, objective, method)
            tasks += ts
            plan.append((name, objective, ts))
    run_tasks(tasks, workers=workers, dask_scheduler=dask_scheduler, progress=progress,
              description="certifying VoI-Lib")
    out = {"version": VERSION, "voiopt_version": _version(), "instances": {}}
    for name, objective, ts in plan:
        entry = out["instances"].setdefault(name, {"sha256": instance_hash(lib[name]), "certificates": {}})
        results = [load_result(t.out_path) for t in ts]
        entry["certificates"][objective] = certificate_of(lib[name], objective, results)
    with progress_bar(progress and bool(lossy_lib)) as bar:
        task = bar.add_task("certifying VoI-Lib's lossy set", total=len(lossy_lib) * len(OBJECTIVES))
        for name, inst in lossy_lib.items():
            stamp = {"voiopt_version": _version(), "instance_sha256": instance_hash(inst)}
            out["instances"][name] = lossy.certify_instance(inst, work, stamp, time_limit=time_limit,
                                                            memory_limit=memory_limit, tick=lambda: bar.advance(task))
    out["instances"] = {n: out["instances"][n] for n in every if n in out["instances"]}  # the library's order
    lossy.copy_policies({n: out["instances"][n] for n in lossy_lib}, work, target)  # beside certificates.json
    path = target / "certificates.json"
    if only is not None and path.exists():  # --only updates those entries and keeps the others
        kept = read_json(path).get("instances", {})
        for name, entry in kept.items():
            if name in every and entry.get("sha256") == instance_hash(every[name]):
                out["instances"].setdefault(name, entry)
        out["instances"] = {n: out["instances"][n] for n in every if n in out["instances"]}
    write_json_atomic(path, out)
    return path
