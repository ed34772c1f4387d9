"""Write the MILP as MPS or LP for any MILP solver (Gurobi, CPLEX, SCIP)."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.errors import OptionError
from voiopt.objectives import Worth
from voiopt.runtime.files import atomic_write
from voiopt.solvers.milp.formulation import build, build_covering
from voiopt.solvers.milp.model import Model, new_highs
from voiopt.solvers.milp.uploads import structure

EXPORT_FORMATS = (".mps", ".lp")


def export(instance: Instance, objective: str, path: str | os.PathLike, covering_level: int | None = None) -> Model:
    """Write the MILP of ``objective`` as MPS or LP (by extension), with comment lines on its
    objective and precision (``describe``): mean VoI in bit/s and min VoI as ln(bit/s)
    maximised (``export_model``); mean or max AoI minimised. For ``min-voi``
    and ``max-aoi``, ``covering_level`` K writes instead the bisection's covering problem for
    the K-th smallest candidate worth (0-based; ``covering_levels`` counts them): feasible iff
    some plan keeps every sensor at that worth or better in every slot."""
    objective = objectives.get(objective)
    p = Path(path)
    if p.suffix.lower() not in EXPORT_FORMATS:
        raise OptionError(f"model: unknown format {p.suffix or '(none)'!r} of {str(p)!r} (use .mps or .lp)")
    import highspy

    model = export_model(instance, objective, covering_level)
    h = new_highs()
    h.silent()
    h.passModel(model.to_highs_lp(natural_units=True, names=True))
    with tempfile.TemporaryDirectory(prefix="voiopt-export-") as folder:
        tmp = Path(folder) / f"model{Path(path).suffix}"  # the name the user gave picks the format
        if h.writeModel(str(tmp)) == highspy.HighsStatus.kError:
            raise OptionError(f"model: HiGHS could not write {str(p)!r}")
        mark = "\\ " if p.suffix.lower() == ".lp" else "* "
        with atomic_write(p) as out, open(tmp, encoding="utf-8") as text:  # a cut-off model never replaces the file
            out.write("".join(mark + line + "\n" for line in describe(model)))
            shutil.copyfileobj(text, out)
    return model


def export_model(instance: Instance, objective: str, covering_level: int | None = None) -> Model:
    """The model ``export`` writes (and ``cvxpy_problem`` holds): ``min-voi`` in log-worths,
    the others with z in units of ``default_scale`` (the mean cap on a slot's least worth for
    ``mean-min-voi``), or the covering problem of ``covering_level``. (For ``mean-min-voi`` a
    unit below the optimum, the value of a plan without uploads, was tried: HiGHS then stopped
    at plans 100 % short on two of the extreme-worth networks that the mean cap solves.)"""
    objective = objectives.get(objective)
    if covering_level is not None:
        return _covering(instance, objective, covering_level)
    if objective.worth == Worth.VOI and not objective.per_slot:  # min-voi in ln V: the same optimal plans, worths a solver resolves
        return build(instance, objective, log_worth=True)
    return build(instance, objective)  # mean-min-voi in bit/s, z in units of the mean cap (default_scale)


def describe(model: Model) -> list[str]:
    """The comment lines at the top of an exported file: what the objective means, and the
    model's precision (docs/milp.md, "Other solvers")."""
    if model.aggregate == "covering":
        return ["voiopt covering problem: feasible iff some plan keeps every sensor at the threshold or better"]
    if model.log_worth:
        return ["voiopt min-voi model in log-worths: maximised objective = ln(min VoI / (1 bit/s)) (nats).",
                "z = ln V; exp(objective) is the min-voi in bit/s. Worths are the simulator's to 1e-15 relative,",
                "V below 2.2e-308 bit/s is one value; a solver's tolerance eps is a relative error of about eps in V.",
                "Read the plan back with voiopt import-solution: its simulated value is the result."]
    if model.structure.kind == Worth.VOI:
        return [f"voiopt {model.objective} model: maximised objective = mean over slots of the least VoI, bit/s.",
                f"z_t in units of {model.scale!r} bit/s (the mean over slots of the cap on a slot's least worth).",
                "Precision: a solver's feasibility tolerance eps lets a slot's least worth read up to about",
                "eps x (z unit + the slot's cap) high; the plan read back by voiopt import-solution is simulated."]
    return [f"voiopt {model.objective} model: minimised objective in slots (ages are integers)."]


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
