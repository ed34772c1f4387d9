"""The story of a plan: what the viewer (``voiopt show``) and the animation show, slot by slot.

Every number is the simulator's (``voiopt.core.simulate.simulate``) of the plan: a result's own
metrics are checked against it (under lossy links, against the plan's exact expectation, or the
policy's instance and exact value: ``check_result``), never drawn. One ``Entry`` per result or plan file; ``story``
turns entries on one instance into the compact JSON the page embeds.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from voiopt.core.expectation import expected_metrics
from voiopt.core.instance import Instance, show
from voiopt.core.links import is_lossy
from voiopt.core.plan import FleetPlan, Plan, made_for, plan_of
from voiopt.core.result import BoundKind, Evaluation, Result, agrees, disagreement
from voiopt.core.simulate import Trajectory, check_plan, simulate
from voiopt.errors import OptionError, PlanError, VoioptError
from voiopt.objectives import DEFAULT, OBJECTIVES, show_gap
from voiopt.runtime.files import read_json, reading


@dataclass(frozen=True)
class Entry:
    """One plan to show: from a result (method, status, value, bound, gap) or a plan file."""

    label: str
    plan: Plan | FleetPlan | None  # None for a policy (lossy links), which ``policy`` holds
    objective: str
    method: str | None = None
    status: str | None = None
    value: float | None = None
    bound: float | None = None
    gap: float | None = None
    bound_kind: BoundKind | None = None
    evaluation: Evaluation | None = None  # lossy links (with samples and value_ci when monte-carlo)
    samples: int | None = None
    value_ci: tuple[float, float] | None = None
    policy: Any = None  # a voiopt.Policy, shown by one sampled run
    metrics: dict | None = None  # the result's stored metrics, checked as plot checks them

    @property
    def gap_kind(self) -> str:
        """How far a gap is to be trusted, in gap-report's words (MODEL.md 6, 11): "statistical"
        to a bound estimated from samples (information relaxation); else "estimate" for a Monte
        Carlo value (its gap to a proven bound is an estimate too); else "proven" (an exact value
        and an exact or lossless bound, or a lossless result's)."""
        if self.bound_kind is not None and not self.bound_kind.proven:
            return "statistical"
        return "estimate" if self.evaluation == Evaluation.MONTE_CARLO else "proven"

    @property
    def gap_range(self) -> tuple[float, float] | None:
        """A Monte Carlo value's gap anywhere in its CI (lowest, highest; signed, as gap-report's), or None."""
        if self.evaluation != Evaluation.MONTE_CARLO or self.value_ci is None or self.bound is None:
            return None
        from voiopt.experiments.lossy_gaps import gap_range

        low, high = gap_range(self.objective, self.value_ci, self.bound)
        return None if low is None else (low, high)


def read_entry(path: str | os.PathLike) -> tuple[Entry, str | None]:
    """A result or plan file as an Entry, and the instance it names (None: it names none).
    Every error names the file."""
    name = os.fsdecode(path)
    d = read_json(path, error=VoioptError)
    if isinstance(d, dict) and "status" in d:  # a result of voiopt solve
        try:
            result = Result.from_dict(d)
        except VoioptError as e:
            raise VoioptError(f"{name}: {e}") from None
        policy = _policy_beside(name, d) if result.plan is None else None
        if result.plan is None and policy is None:
            raise OptionError(f"{name}: the result has no plan to show (status {result.status})")
        ci = d.get("value_ci") if isinstance(d.get("value_ci"), list) and len(d["value_ci"]) == 2 else None
        samples = d.get("samples") if isinstance(d.get("samples"), int) else None
        return Entry(Path(name).name, result.plan, result.objective, result.method, result.status, result.value,
                     result.bound, result.gap, result.bound_kind, result.evaluation, samples,
                     None if ci is None else (float(ci[0]), float(ci[1])), policy, result.metrics), result.instance
    plan = plan_of(d, name)  # a plan, or a plan with instance and objective (a VoI-Lib submission)
    objective = d.get("objective", DEFAULT) if isinstance(d, dict) else DEFAULT
    if objective not in OBJECTIVES:
        raise OptionError(f"{name}: objective: must be one of {', '.join(OBJECTIVES)}, got {show(objective)}")
    return Entry(Path(name).name, plan, objective), made_for(d) or (
        d.get("instance") if isinstance(d, dict) and isinstance(d.get("instance"), str) else None)


def _policy_beside(name: str, d: dict) -> Any:
    """The policy a policy result names (``solver.policy_file``, beside the result), or None."""
    solver = d.get("solver") if isinstance(d.get("solver"), dict) else {}
    file = solver.get("policy_file")
    if not isinstance(file, str):
        return None
    from voiopt.core.policy import Policy

    path = Path(name).parent / file
    with reading(f"{name}: its policy"):
        return Policy.load(path)


def policy_run(instance: Instance, policy: Any, seed: int) -> tuple[Plan | FleetPlan, Plan | FleetPlan, dict]:
    """One sampled run of a policy (scenario 0 of ``sample_scenarios(instance, 1, seed)``): the
    uploads it scheduled, then the lossless plan it realised and the page's ``run`` (``_realised``)."""
    from voiopt.core.policy_value import trace
    from voiopt.core.scenarios import sample_scenarios

    idx, sched, ok = trace(policy, sample_scenarios(instance, 1, seed)[0])
    return (Plan.from_indices(instance, idx, sched), *_realised(instance, idx, sched, ok, seed))


def _realised(instance: Instance, idx, sched, ok, seed: int) -> tuple[Plan | FleetPlan, dict]:
    """A run's lossless plan (each failed upload unscheduled, which the simulator then values)
    and the page's ``run``: its seed and, per robot and slot, whether a scheduled upload failed."""
    failed = (np.atleast_2d(sched) >= 0) & ~np.atleast_2d(ok)
    return Plan.from_indices(instance, idx, np.where(ok, sched, -1)), {"seed": seed, "failed": failed.tolist()}


def trajectory(instance: Instance, entry: Entry, where: str = "the instance") -> Trajectory:
    """The simulated trajectory of a plan entry, its result checked first (``check_result``)."""
    if entry.plan is None:
        raise OptionError(f"{entry.label}: a policy result has no plan to draw here: voiopt show draws a sampled "
                          "run of its policy")
    try:
        traj = simulate(instance, entry.plan)
    except PlanError as e:
        raise PlanError(f"{entry.label}: {e}") from None
    check_result(instance, entry, where, traj.metrics)
    return traj


def lossy_caption(instance: Instance) -> str:
    """What an animation of a plan on a lossy instance says under its frames: they are the run in
    which every upload succeeds, not a sampled one ("" on an instance that is not lossy)."""
    if not is_lossy(instance):
        return ""
    return "lossy links: drawn as if every upload succeeds; voiopt show draws a sampled run"


REFUSED = "give the instance it was solved on with --instance (or the file was edited)"


def check_result(instance: Instance, entry: Entry, where: str, simulated: dict[str, float] | None = None) -> None:
    """Refuse (one line) a result that ``instance`` (found at ``where``) does not give, so that
    no page or animation labels another instance's value as this one's:

    - a plan: its stored value and metrics against the plan's own on the instance: simulated
      without losses, the exact expectation (``expected_metrics``) on a lossy instance, as
      ``voiopt plot`` checks them. A plan result whose value says it is a Monte Carlo
      estimate (no voiopt method writes one) has nothing exact to meet and is not checked;
    - a policy: the instance its policy file was made for (links included) must be this one;
      where the result's value is exact, the policy's exact value (``policy_value.exact_value``)
      is computed again and must be it. A Monte Carlo value is not sampled again.
    """
    if entry.value is None:
        return
    if entry.policy is not None:
        _check_policy(instance, entry, where)
        return
    if entry.evaluation == Evaluation.MONTE_CARLO:
        return
    metrics = expected_metrics(instance, entry.plan) if is_lossy(instance) else simulated
    if metrics is None:
        metrics = expected_metrics(instance, entry.plan)
    differ = disagreement(entry.metrics, metrics) or disagreement({entry.objective: entry.value}, metrics)
    if differ:
        what = "exact expectation" if is_lossy(instance) else "simulated"
        raise OptionError(f"{entry.label}: its plan on {where} does not give what the result says "
                          f"({differ.replace(' simulated', ' ' + what)}): {REFUSED}")


def _check_policy(instance: Instance, entry: Entry, where: str) -> None:
    mine, theirs = entry.policy.instance.to_dict(), instance.to_dict()
    if mine.get("links") != theirs.get("links"):
        raise OptionError(f"{entry.label}: its policy was made for links {show(mine.get('links'))}, {where} has "
                          f"{show(theirs.get('links'))}: {REFUSED}")
    if mine != theirs:
        field = next(k for k in sorted(set(mine) | set(theirs)) if mine.get(k) != theirs.get(k))
        raise OptionError(f"{entry.label}: its policy was made for another instance than {where} "
                          f"({field} differs): {REFUSED}")
    if entry.evaluation != Evaluation.EXACT:
        return
    from voiopt.core.policy_value import AVERAGED, MAX_STATES, exact_value

    if entry.objective not in AVERAGED:
        return
    value = exact_value(entry.policy, entry.objective, MAX_STATES)
    if value is not None and not agrees(entry.value, value):
        raise OptionError(f"{entry.label}: its policy on {where} does not give what the result says "
                          f"({entry.objective} {show(entry.value)} stored, {value!r} exact): {REFUSED}")


def _number(v: Any) -> float | str | None:
    """A float for JSON: full precision (repr round-trips), non-finite values as strings
    ("Infinity") that the page turns back into numbers."""
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else str(v).replace("inf", "Infinity").replace("nan", "NaN")


def _rows(a) -> list:
    return [[_number(x) for x in row] for row in a.tolist()]


def sampled_run(instance: Instance, plan: Plan | FleetPlan, seed: int) -> tuple[Plan | FleetPlan, dict] | None:
    """Lossy links (MODEL.md section 11): one sampled run of the plan, as the lossless plan it
    becomes (each failed upload unscheduled, which the simulator then values) and the page's
    ``run``: its seed and, per robot and slot, whether a scheduled upload failed. The outcomes
    are scenario 0 of ``voiopt.core.scenarios.sample_scenarios(instance, 1, seed)`` (coupled
    uniforms U(t, i)). Without ``links`` every upload succeeds: None, and nothing is drawn."""
    if instance.links is None:
        return None
    from voiopt.core import scenarios

    idx, sched = check_plan(instance, plan)
    ok = scenarios.successes(instance, idx, sched, scenarios.sample_scenarios(instance, 1, seed)[0])
    return _realised(instance, idx, sched, ok, seed)


def story(instance: Instance, entries: list[Entry], where: str = "the instance", seed: int = 0) -> dict[str, Any]:
    """The page's data: the instance (area, blocked points, robots' starts and ends, sensors)
    and per entry its header and its simulated story: p_k(t) for t = 0..T-1, u_k(t) (-1: none),
    A_i(t) and V_i(t) for t = 0..T (row t: before slot t's upload takes effect). Under lossy
    links (``sampled_run``) the ages and values are those of one sampled run, seeded by ``seed``,
    and ``simulated`` holds that run's metrics, not the plan's expected ones; a plan file's
    ``value`` is then its exact expectation (``expected_metrics``). ``check_result`` refuses a
    result the instance does not give."""
    T = instance.horizon
    out = []
    for e in entries:
        if e.policy is not None:  # a policy: one sampled run, its scheduled uploads drawn, failures marked
            check_result(instance, e, where)
            shown, realised, run = policy_run(instance, e.policy, seed)
            robots, traj, sampled = shown.robots, simulate(instance, realised), (realised, run)
        else:
            traj = trajectory(instance, e, where)
            robots = e.plan.robots
            sampled = sampled_run(instance, e.plan, seed)
            if sampled is not None:  # the run's ages and values: the plan with its failed uploads unscheduled
                traj = simulate(instance, sampled[0])
                if e.value is None:  # a plan file: its exact expected objective, which no run shows
                    e = replace(e, value=expected_metrics(instance, e.plan)[e.objective], evaluation=Evaluation.EXACT)
        out.append({
            "label": e.label, "kind": "plan" if e.policy is None else "policy", "method": e.method, "objective": e.objective, "status": e.status,
            "value": _number(e.value), "bound": _number(e.bound), "gap": _number(e.gap),
            "gapText": show_gap(e.gap), "gapKind": e.gap_kind,
            "gapRange": None if e.gap_range is None else [show_gap(g) for g in e.gap_range],
            "boundKind": e.bound_kind, "evaluation": e.evaluation,
            "samples": e.samples, "valueCi": None if e.value_ci is None else [_number(v) for v in e.value_ci],
            "simulated": {k: _number(v) for k, v in traj.metrics.items()},
            "x": [[_number(x) for x, _ in r.positions] for r in robots],
            "y": [[_number(y) for _, y in r.positions] for r in robots],
            "u": [[-1 if u is None else int(u) for u in r.schedule] for r in robots],
            "aoi": traj.aoi.tolist(), "voi": _rows(traj.voi),
            "run": None if sampled is None else sampled[1],
        })
    return {
        "instance": {
            "name": instance.name, "width": instance.width, "height": instance.height, "step": instance.step,
            "T": T, "d_th": instance.channel.d_th, "blocked": [list(p) for p in instance.blocked],
            "robots": [{"start": list(r.start), "end": None if r.end is None else list(r.end),
                        "max_moves": r.max_moves} for r in instance.robots],
            "sensors": [{"x": s.position[0], "y": s.position[1], "rho": s.rho} for s in instance.sensors],
        },
        "results": out,
    }
