"""Write the MILP as MPS or LP for any MILP solver (Gurobi, CPLEX, SCIP)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.errors import OptionError
from voiopt.objectives import check_objective
from voiopt.runtime.files import atomic_path
from voiopt.solvers.milp.formulation import build, build_covering
from voiopt.solvers.milp.model import Model, new_highs
from voiopt.solvers.milp.uploads import structure

EXPORT_FORMATS = (".mps", ".lp")


def export(instance: Instance, objective: str, path: str | os.PathLike, covering_level: int | None = None) -> Model:
    """Write the MILP of ``objective`` as MPS or LP (by extension), objective in its own units
    and sense (mean or min VoI in bit/s maximised; mean or max AoI minimised). For ``min-voi``
    and ``max-aoi``, ``covering_level`` K writes instead the bisection's covering problem for
    the K-th smallest candidate worth (0-based; ``covering_levels`` counts them): feasible iff
    some plan keeps every sensor at that worth or better in every slot."""
    check_objective(objective)
    p = Path(path)
    if p.suffix.lower() not in EXPORT_FORMATS:
        raise OptionError(f"model: unknown format {p.suffix or '(none)'!r} of {str(p)!r} (use .mps or .lp)")
    import highspy

    if covering_level is None:
        model = build(instance, objective)
    else:
        model = _covering(instance, objective, covering_level)
    h = new_highs()
    h.silent()
    h.passModel(model.to_highs_lp(natural_units=True, names=True))
    with atomic_path(p) as tmp:  # a cut-off model never replaces the file
        status = h.writeModel(str(tmp))
        if status == highspy.HighsStatus.kError:
            raise OptionError(f"model: HiGHS could not write {str(p)!r}")
    return model


def covering_levels(instance: Instance, objective: str) -> np.ndarray:
    """The candidate worths of the bisection for ``min-voi`` or ``max-aoi``, ascending (V in
    bit/s, or -A)."""
    if objectives.get(objective).per_slot:
        raise OptionError(f"--covering-level: covering problems exist for min-voi and max-aoi, not {objective}")
    return structure(instance, objectives.get(objective).worth).candidates()


def _covering(instance: Instance, objective: str, level: int) -> Model:
    cand = covering_levels(instance, objective)
    if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or not 0 <= level < len(cand):
        raise OptionError(f"--covering-level: must be an integer in 0..{len(cand) - 1}, got {level!r}")
    model = build_covering(instance, objective, float(cand[level]))
    if model is None:
        raise OptionError(f"--covering-level: level {level} (worth {cand[level]:.6g}) cannot be reached by any upload: "
                          "the covering problem is infeasible before it is built")
    return model
