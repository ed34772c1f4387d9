"""Write the MILP as MPS or LP for any MILP solver (Gurobi, CPLEX, SCIP)."""

from __future__ import annotations

import os
from pathlib import Path

from voiopt.errors import OptionError
from voiopt.instance import Instance
from voiopt.models.milp.formulation import build
from voiopt.models.milp.model import Model
from voiopt.objectives import check_objective

EXPORT_FORMATS = (".mps", ".lp")


def export(instance: Instance, objective: str, path: str | os.PathLike) -> Model:
    """Write the MILP of ``objective`` as MPS or LP (by extension), objective in its own units
    and sense (mean or min VoI in bit/s maximised; mean or max AoI minimised)."""
    check_objective(objective)
    p = Path(path)
    if p.suffix.lower() not in EXPORT_FORMATS:
        raise OptionError(f"model: unknown format {p.suffix or '(none)'!r} of {str(p)!r} (use .mps or .lp)")
    import highspy

    model = build(instance, objective)
    h = highspy.Highs()
    h.silent()
    h.passModel(model.to_highs_lp(natural_units=True, names=True))
    p.parent.mkdir(parents=True, exist_ok=True)
    status = h.writeModel(str(p))
    if status == highspy.HighsStatus.kError:
        raise OptionError(f"model: HiGHS could not write {str(p)!r}")
    return model
