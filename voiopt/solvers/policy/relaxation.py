"""The information-relaxation bound on the optimal policy's value (MODEL.md section 11).

For a scenario w (uniforms U(t, i), voiopt.core.scenarios), J*(w) is the best plan that knows
w in advance: the lossless problem in which sensor i's upload from point p in slot t is
available only where it would succeed, U(t, i) < p_i(d). No policy's realised value on w is
above J*(w), so E[J*(w)] bounds the optimal policy. Over K scenarios the bound is the
one-sided 95 % upper confidence limit of the mean of J*(w) (lower when minimising), capped by
the lossless bound: statistical, never proven.

J*(w) is solved exactly by the layered expectimax of ``layered.py`` with the scenario's 0/1
availability as its success table, which makes it a deterministic programme over the states
(slot, position, moves used, A, q) reachable from the start. That programme has no dominance
pruning (dp's label setting has, but takes no per-slot availability), so this bound is for the
instances the expectimax reaches (docs/policy.md gives where that ends), K times over.
"""

from __future__ import annotations

import math

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.links import success_table
from voiopt.core.result import BoundKind
from voiopt.core.scenarios import CONFIDENCE, sample_scenarios
from voiopt.errors import OptionError
from voiopt.grid import lattice as lattice_mod
from voiopt.runtime.stop import Stop, Stopped
from voiopt.solvers.policy.layered import exact_search, warm_up

DEFAULT_SAMPLES = 100


def availability(instance: Instance, u: np.ndarray, table: np.ndarray | None = None) -> np.ndarray:
    """(T, points, N) 0/1: where an upload would succeed in scenario ``u`` ((T, N) uniforms)."""
    table = success_table(instance, lattice_mod.build(instance)) if table is None else table
    return (u[:, None, :] < table[None, :, :]).astype(float)


def scenario_optimum(instance: Instance, objective: str, u: np.ndarray, stop: Stop | None = None,
                     table: np.ndarray | None = None) -> float:
    """J*(w): the exact optimum of the lossless problem that knows scenario ``u``."""
    return exact_search(instance, objective, availability(instance, u, table), stop).solve()


def information_relaxation(instance: Instance, objective: str, *, samples: int = DEFAULT_SAMPLES, seed: int = 0,
                           lossless_bound: float | None = None, stop: Stop | None = None,
                           scenarios: np.ndarray | None = None) -> dict | None:
    """The statistical bound and its details: ``bound`` (the one-sided 95 % confidence limit,
    capped by ``lossless_bound``), ``mean``, ``samples``, ``confidence``, ``capped``, and each
    scenario's J*(w) in ``values``. None if a stop came before two scenarios were solved.
    ``scenarios`` (K, T, N) replaces the K drawn from ``seed``."""
    # the Student-t quantile (scipy.stats takes seconds to import)
    from scipy.special import stdtrit

    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 2:
        raise OptionError(f"--ir-samples: must be an integer >= 2, got {samples!r}")
    scenarios = sample_scenarios(instance, samples, seed) if scenarios is None else scenarios
    warm_up()
    table = success_table(instance, lattice_mod.build(instance))
    values = []
    for u in scenarios:
        try:
            values.append(scenario_optimum(instance, objective, u, stop, table))
        except Stopped:
            break
        if stop is not None and stop.check() is not None:
            break
    if len(values) < 2:
        return None
    x = np.asarray(values)
    n = len(x)
    half = float(stdtrit(n - 1, CONFIDENCE) * x.std(ddof=1) / math.sqrt(n))
    maximise = objectives.get(objective).maximise
    limit = float(x.mean() + half) if maximise else float(x.mean() - half)
    capped = lossless_bound is not None and (limit > lossless_bound if maximise else limit < lossless_bound)
    bound = float(lossless_bound) if capped else limit
    return {"bound": bound, "mean": float(x.mean()), "samples": n, "confidence": CONFIDENCE, "capped": bool(capped),
            "values": x.tolist(), "seed": seed}


def policy_bound(instance: Instance, objective: str, lossless: float | None, *, ir_samples: int = 0, seed: int = 0,
                 stop: Stop | None = None) -> tuple[float | None, BoundKind | None, dict, dict | None]:
    """A policy's bound: the information relaxation over ``ir_samples`` scenarios (0: none) where
    it is tighter than the lossless bound (statistical), else the lossless bound (proven).
    Returns the bound, its kind, the fields Result.lossy takes beside them, and the
    relaxation's record for the result's ``solver`` (None where it was not used)."""
    if ir_samples:
        ir = information_relaxation(instance, objective, samples=ir_samples, seed=seed, lossless_bound=lossless,
                                    stop=stop)
        if ir is not None and not ir["capped"]:
            return (ir["bound"], BoundKind.INFORMATION_RELAXATION,
                    {"bound_samples": ir["samples"], "bound_confidence": ir["confidence"]},
                    {k: ir[k] for k in ("mean", "samples", "seed", "capped")})
    return lossless, None if lossless is None else BoundKind.LOSSLESS, {}, None
