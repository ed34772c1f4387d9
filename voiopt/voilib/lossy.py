"""VoI-Lib's lossy set (MODEL.md section 11): instances with lossy links, and their certificates.

A lossy certificate is labelled as section 11 asks (docs/voilib.md, "The lossy set"):

- averaged objectives (``per_slot``): where ``policy-dp`` finishes, status ``optimal``: the
  optimal policy's value, computed again from its table by ``policy_value.exact_value`` (never
  the programme's number), ``bound_kind`` exact. Otherwise the best known plan's exact expected
  value, the lossless bound (proven) and, where it could be computed in the time given, the
  information-relaxation bound beside it (statistical, with its samples and confidence; never
  the certificate's ``bound``); status ``bounded``;
- bottleneck objectives: the best plan's exact expected value and the lossless bound (proven),
  status ``bounded``: a plan is not a policy, and the optimal policy is not built.

``bound`` is always proven (exact or lossless), so the interval [value, bound] means what it
means for the lossless entries, and ``merge`` compares it the same way. The best known plan is
the best, in exact expectation, of dp's lossless optima for the four objectives. An optimal
policy is stored beside the certificate (``policy_file``, ``policy_sha256``: its table over the
states it reaches) where its file is under POLICY_LIMIT bytes; otherwise the value alone.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

from voiopt import objectives
from voiopt.core import instance as instance_mod
from voiopt.core.instance import Instance
from voiopt.core.links import is_lossy
from voiopt.core.policy_value import exact_value
from voiopt.core.result import OPTIMAL_RTOL, BoundKind, Evaluation
from voiopt.errors import OptionError, VoioptError
from voiopt.networks.generate import generate_set
from voiopt.objectives import OBJECTIVES, best, gap
from voiopt.runtime.files import atomic_write, read_json, safe_name, write_json_atomic
from voiopt.runtime.status import Status
from voiopt.runtime.stop import watch
from voiopt.voilib.certificates import make_provenance, today

BERNOULLI = lambda p: {"model": "bernoulli", "success": p}  # noqa: E731
RAYLEIGH = lambda db: {"model": "rayleigh", "snr_threshold_db": db}  # noqa: E731

# The lossy set of version 1.3: (name, what it is drawn from, links). A name of the lossless
# ladder is that frozen network with links added (its lossless certificate is the lossy
# entry's lossless bound); a dict is drawn by generate_set(1, seed=LOSSY_SEED + k, ...), named
# name-000.
LOSSY_LADDER: list[tuple[str, str | dict[str, Any], dict[str, Any]]] = [
    ("lossy-case-study-b90", "case-study", BERNOULLI(0.9)),
    ("lossy-case-study-b70", "case-study", BERNOULLI(0.7)),
    ("lossy-case-study-b50", "case-study", BERNOULLI(0.5)),
    ("lossy-paper-n3-t12-b70", dict(n_sensors=3, horizon=12), BERNOULLI(0.7)),
    ("lossy-paper-n3-t14-r27", dict(n_sensors=3, horizon=14), RAYLEIGH(27.0)),
    ("lossy-paper-n4-t12-b70", dict(n_sensors=4, horizon=12), BERNOULLI(0.7)),
    ("lossy-paper-n4-t30-b70", "paper-n4-t30-000", BERNOULLI(0.7)),
]
LOSSY_SEED = 3030
IR_SAMPLES = 30  # scenarios of the information-relaxation bound, where it is tried
POLICY_LIMIT = 1_000_000  # bytes: an optimal policy's file is stored beside its certificate below this
SCORE_SEED, SCORE_SAMPLES = 2031, 1000  # the library's fixed scenarios for a policy too big to value exactly


def lossy_ladder(lossless: dict[str, Instance]) -> list[Instance]:
    """The lossy set, drawn afresh; ``lossless`` holds the lossless ladder's instances by name."""
    out = []
    for k, (name, source, links) in enumerate(LOSSY_LADDER):
        if isinstance(source, str):
            out.append(instance_mod.from_dict(lossless[source].to_dict() | {"name": name, "links": links}))
        else:
            out += generate_set(1, seed=LOSSY_SEED + k, name=name, links=links, **source)
    return out


def links_text(inst: Instance) -> str:
    """An instance's links as ``voiopt generate --links`` spells them, or "-"."""
    links = inst.links
    if links is None:
        return "-"
    return f"bernoulli:{links.success:g}" if links.model == "bernoulli" else f"rayleigh:{links.snr_threshold_db:g}"


def label(cert: dict[str, Any]) -> str:
    """What a lossy certificate's table cell says after its numbers: the bound's kind."""
    return f" ({cert['bound_kind']})" if cert.get("bound_kind") else ""


# ------------------------------------------------------------------------- certification


def limits(time_limit: float, memory_limit: float | None) -> dict[str, float]:
    """A solve's limits: the memory limit only where one was given (else the method's default)."""
    return {"time_limit": time_limit} | ({} if memory_limit is None else {"memory_limit": memory_limit})


def plans(inst: Instance, time_limit: float, memory_limit: float | None) -> tuple[dict, dict]:
    """dp's lossless optimum for each objective, valued exactly on ``inst``: (results by
    objective, checks by objective)."""
    from voiopt.solvers import solve

    results = {o: solve(inst, "dp", o, **limits(time_limit, memory_limit)) for o in OBJECTIVES}
    return results, {o: {"status": r.status, "value": r.value, "bound": r.bound, "runtime_s": r.runtime_s,
                         "lossless_status": r.solver.get("lossless_status")} for o, r in results.items()}


def best_plan(objective: str, results: dict) -> tuple[Any, float, str]:
    """The best, in exact expectation for ``objective``, of the plans of ``results``: (plan,
    its exact expected value, the objective dp solved for it)."""
    valued = {o: r.metrics[objective] for o, r in results.items() if r.plan is not None}
    value = best(objective, list(valued.values()))
    source = next(o for o, v in valued.items() if v == value)
    return results[source].plan, value, source


def policy_optimum(inst: Instance, objective: str, time_limit: float, memory_limit: float | None) -> dict[str, Any]:
    """policy-dp's run: on success, the optimal policy's exact value re-computed from its table
    (``value``), the programme's bound and the states; otherwise the stop's status."""
    from voiopt.solvers import solve

    r = solve(inst, "policy-dp", objective, **limits(time_limit, memory_limit))
    out = {"status": r.status, "bound": r.bound, "bound_kind": r.bound_kind, "runtime_s": r.runtime_s,
           "states": r.solver.get("policy_states"), "value": None}
    if r.status == Status.OPTIMAL:
        out["policy"] = r.policy
        out["value"] = exact_value(r.policy, objective, max_states=len(r.policy.table) + 1)  # never the programme's
    else:
        out["stopped"] = r.solver.get("stopped")
    return out


def relaxation(inst: Instance, objective: str, lossless_bound: float, budget: float,
               memory_limit: float | None) -> dict[str, Any] | None:
    """The information-relaxation bound over IR_SAMPLES scenarios, or None where fewer than two
    scenario problems were solved within ``budget`` seconds (statistical: never ``bound``)."""
    from voiopt.solvers.policy.relaxation import information_relaxation

    with watch(budget, memory_limit) as stop:
        ir = information_relaxation(inst, objective, samples=IR_SAMPLES, seed=LOSSY_SEED,
                                    lossless_bound=lossless_bound, stop=stop)
    if ir is None:
        return None
    return {"bound": ir["bound"], "mean": ir["mean"], "samples": ir["samples"], "confidence": ir["confidence"],
            "capped": ir["capped"], "seed": ir["seed"], "bound_kind": BoundKind.INFORMATION_RELAXATION.value}


def policy_name(name: str, objective: str) -> str:
    """Where a certificate's optimal policy is kept, relative to its certificates.json."""
    return f"policies/{safe_name(name)}__{objective}.policy.json"


def file_hash(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def store_policy(policy, folder: Path, name: str, objective: str) -> dict[str, Any]:
    """Save an optimal policy under ``folder`` if its file is small (POLICY_LIMIT): the
    certificate's ``policy_file`` and ``policy_sha256``, or ``policy_file`` None."""
    rel = policy_name(name, objective)
    path = folder / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    policy.save(path)
    if path.stat().st_size >= POLICY_LIMIT:
        path.unlink()
        return {"policy_file": None, "policy_sha256": None}
    return {"policy_file": rel, "policy_sha256": file_hash(path)}


def copy_policies(instances: dict[str, Any], source: Path, target: Path) -> None:
    """Copy the policy files that the certificates of ``instances`` name from the folder
    ``source`` to ``target`` (each relative to its certificates.json), each checked against its
    sha256 first; a missing or changed one refuses, naming it."""
    for entry in instances.values():
        for cert in entry["certificates"].values():
            rel = cert.get("policy_file")
            if rel is None or source.resolve() == target.resolve():
                continue
            path = source / rel
            if not path.is_file() or file_hash(path) != cert.get("policy_sha256"):
                raise OptionError(f"{path}: policy_file: missing, or not the policy its certificate's sha256 names")
            (target / rel).parent.mkdir(parents=True, exist_ok=True)
            with atomic_write(target / rel, binary=True) as f:
                f.write(path.read_bytes())


def certificate_of(inst: Instance, objective: str, results: dict, checks: dict, *, time_limit: float,
                   memory_limit: float | None, stamp: dict[str, str], folder: Path) -> dict[str, Any]:
    """The labelled certificate of one lossy instance and objective (the module's docstring);
    ``stamp`` holds its ``voiopt_version`` and ``instance_sha256``; an optimal policy's file
    goes under ``folder``."""
    objective = objectives.get(objective)
    plan, plan_value, plan_source = best_plan(objective, results)
    lossless_bound = results[objective].bound
    if lossless_bound is None or results[objective].solver.get("lossless_status") != Status.OPTIMAL:
        raise VoioptError(f"certify: {inst.name} {objective}: dp did not prove the lossless optimum "
                          f"({results[objective].solver.get('lossless_status')}) in {time_limit:g} s")
    runs: dict[str, Any] = {"dp": checks[objective]}  # each certifying method's own, as for the lossless entries
    cert: dict[str, Any] = {
        "objective": objective, "links": inst.to_dict()["links"], "plan": plan.to_dict(), "method": "dp",
        "plan_objective": plan_source, "plan_value": plan_value, "plan_evaluation": Evaluation.EXACT.value,
        "lossless_bound": lossless_bound, "information_relaxation": None, "policy_file": None, "policy_sha256": None,
        "evaluation": Evaluation.EXACT.value, "samples": None, "value_ci": None,
    }
    if objectives.BY_NAME[objective].per_slot:
        run = policy_optimum(inst, objective, time_limit, memory_limit)
        policy = run.pop("policy", None)
        runs["policy-dp"] = run
        if run["value"] is not None:
            if gap(run["value"], run["bound"]) > OPTIMAL_RTOL:
                raise VoioptError(f"certify: {inst.name} {objective}: the optimal policy's table is worth "
                                  f"{run['value']!r}, its programme says {run['bound']!r}")
            cert.update(status="optimal", value=run["value"], bound=run["value"], value_of="policy",
                        bound_kind=BoundKind.EXACT.value, bound_method="policy-dp", value_method="policy-dp",
                        policy_states=run["states"], **store_policy(policy, folder, inst.name, objective))
        else:
            cert["information_relaxation"] = relaxation(inst, objective, lossless_bound, time_limit / 4, memory_limit)
    if "status" not in cert:
        cert.update(status="bounded", value=plan_value, bound=lossless_bound, value_of="plan",
                    bound_kind=BoundKind.LOSSLESS.value, bound_method="dp", value_method="dp")
    cert.update(gap=gap(cert["value"], cert["bound"]), checks=runs, **stamp)
    return {**cert, "provenance": make_provenance(cert, today())}


def certify_instance(inst: Instance, work: Path, stamp: dict[str, str], *, time_limit: float,
                     memory_limit: float | None, tick=lambda: None) -> dict[str, Any]:
    """The certificates of one lossy instance (``stamp``: its ``instance_sha256`` and the
    ``voiopt_version``), each kept in ``work`` as NAME__OBJECTIVE__lossy.json so that an
    interrupted certification resumes (an optimal policy under ``work/policies``); ``tick()``
    after each objective (a progress bar)."""
    if not is_lossy(inst):
        raise VoioptError(f"certify: {inst.name} has no lossy links")
    entry: dict[str, Any] = {"sha256": stamp["instance_sha256"], "certificates": {}}
    results = checks = None
    for objective in OBJECTIVES:
        path = work / f"{safe_name(inst.name)}__{objective}__lossy.json"
        if path.is_file():
            kept = read_json(path)
            rel = kept.get("policy_file")
            if kept.get("instance_sha256") == entry["sha256"] and (rel is None or (work / rel).is_file()):
                entry["certificates"][objective] = kept
                tick()
                continue
        if results is None:
            results, checks = plans(inst, time_limit, memory_limit)
        cert = certificate_of(inst, objective, results, checks, time_limit=time_limit, memory_limit=memory_limit,
                              stamp=stamp, folder=work)
        write_json_atomic(path, cert)
        entry["certificates"][objective] = read_json(path)
        tick()
    return entry
