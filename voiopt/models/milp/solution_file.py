"""Read an external MILP solver's solution back into a plan (``voiopt import-solution``).

The solution is matched to the exported model by column name (docs/milp.md): only the x and y
columns matter, ``x_t<slot>_p<point>`` and ``y_i<sensor>_t<slot>_p<point>``. Two file forms
are read: HiGHS's solution file (``writeSolution``, or ``--solution_file``) and the common
``name value`` lines of a .sol file from SCIP, Gurobi or CPLEX; other lines (headers, comments,
objective values, rows) are skipped, and a column a file leaves out is 0. The plan is then
simulated like any other: the file's own objective value is never used.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from voiopt import objectives
from voiopt._files import MAX_JSON_BYTES
from voiopt.errors import OptionError, PlanError
from voiopt.instance import Instance
from voiopt.models.milp.model import new_highs, path_names, worth_name
from voiopt.models.milp.solution import plan_from_columns
from voiopt.models.uploads import structure
from voiopt.plan import Plan
from voiopt.result import Result


def _existing(path: str | os.PathLike, what: str) -> Path:
    """The file ``path``; an OptionError naming ``what`` if it is missing or a folder."""
    p = Path(path)
    if not p.is_file():
        raise OptionError(f"{what}: {path}: {'a folder, not a file' if p.is_dir() else 'no such file'}")
    return p


def model_names(model: str | os.PathLike) -> tuple[set[str], bool]:
    """The column names of an MPS or LP file (read by HiGHS), and whether it maximises."""
    import highspy

    h = new_highs()
    h.silent()
    _existing(model, "MODEL")
    if h.readModel(str(model)) == highspy.HighsStatus.kError:
        raise OptionError(f"MODEL: HiGHS cannot read {str(model)!r} as MPS or LP")
    lp = h.getLp()
    return set(lp.col_names_), lp.sense_ == highspy.ObjSense.kMaximize


def _check_objective(objective: str, in_model: set[str], maximises: bool, horizon: int) -> None:
    """The model was exported for ``objective``: a mean objective has one worth column per slot
    (z_t1 .. z_tT), a bottleneck one a single z (a covering problem of the bisection has
    neither), and VoI is maximised, AoI minimised."""
    spec = objectives.get(objective)
    per_slot = worth_name(0, 2) in in_model  # z_t1: per-slot worth columns
    if not (per_slot or worth_name(0, 1) in in_model):
        return  # a covering problem (--covering-level): any plan of it is a plan
    if (per_slot != spec.per_slot and horizon > 1) or maximises != (spec.worth == "voi"):
        kind = ("a mean objective's" if per_slot else "a bottleneck objective's") + (
            " VoI model" if maximises else " AoI model")
        raise OptionError(f"--objective: {objective!r} does not match MODEL, {kind}: give the --objective it was "
                          "exported with")


def read_values(solution: str | os.PathLike, names: dict[str, int]) -> dict[str, float]:
    """``name value`` pairs of the known columns in a solution file."""
    p = _existing(solution, "SOLUTION")
    if p.stat().st_size > 8 * MAX_JSON_BYTES:
        raise OptionError(f"SOLUTION: {solution}: larger than {8 * MAX_JSON_BYTES} bytes")
    values = {}
    with open(p, encoding="utf-8", errors="replace") as f:
        for line in f:
            parts = line.split()
            if len(parts) >= 2 and parts[0] in names:
                try:
                    v = float(parts[1])
                except ValueError:
                    raise OptionError(f"SOLUTION: {parts[0]}: must be a number, got {parts[1][:40]!r}") from None
                if not np.isfinite(v):
                    raise OptionError(f"SOLUTION: {parts[0]}: must be a finite number, got {parts[1][:40]!r}")
                values[parts[0]] = v
    return values


INTEGRAL = 1e-5  # how far from 0 or 1 an x or y value may be: Gurobi's and CPLEX's default integrality tolerance


def _check_binary(st, values: dict[str, float], col: np.ndarray, solution) -> None:
    """The x and y values describe one plan: every value 0 or 1 (within INTEGRAL), the robot at
    exactly one point in every slot, and at most one upload per slot, made from that point."""
    for k, v in values.items():
        if min(abs(v), abs(v - 1.0)) > INTEGRAL:
            raise OptionError(f"SOLUTION: {k}: {v:g} is neither 0 nor 1: not an integer solution")
    at = np.where(st.x_col >= 0, col[np.maximum(st.x_col, 0)], 0.0) > 0.5  # (T, n)
    for t in range(st.horizon):
        if at[t].sum() != 1:
            raise OptionError(f"SOLUTION: {solution}: slot {t} has {int(at[t].sum())} points with x_t{t}_p<point> = 1, "
                              "not one (is the file complete?)")
    up = col[st.up_col] > 0.5
    for t in range(st.horizon):
        here = np.flatnonzero(up & (st.up_slot == t))
        if len(here) > 1:
            raise OptionError(f"SOLUTION: {solution}: slot {t} has {len(here)} uploads (y = 1); a slot has one at most")
        for u in here:
            if not at[t, st.up_point[u]]:
                raise OptionError(f"SOLUTION: y_i{st.up_sensor[u]}_t{t}_p{st.up_point[u]} = 1, but the robot is not at "
                                  f"point {st.up_point[u]} in slot {t}")


def import_solution(instance: Instance, objective: str, model: str | os.PathLike,
                    solution: str | os.PathLike) -> Result:
    """A result (method "import") from the solution of the model ``voiopt export`` wrote."""
    objectives.check_objective(objective)
    if instance.fleet:
        raise OptionError(f"import-solution: reads one robot's x_t<slot>_p<point> columns, but {instance.name} has "
                          f"{instance.n_robots} robots (solve the fleet with voiopt solve --method milp)")
    st = structure(instance, objectives.get(objective).worth)
    names = path_names(st)
    in_model, maximises = model_names(model)
    missing = sorted(set(names) - in_model)
    if missing:
        raise OptionError(f"MODEL: its columns are not those voiopt exports for {instance.name} (no {missing[0]}): "
                          "was it exported from another instance?")
    _check_objective(objective, in_model, maximises, instance.horizon)
    values = read_values(solution, names)
    if not any(k.startswith("x_") for k in values):
        raise OptionError(f"SOLUTION: {solution}: no x_t<slot>_p<point> column of the model: not a solution of it")
    col = np.zeros(st.n_base)
    for k, v in values.items():
        col[names[k]] = v
    _check_binary(st, values, col, solution)
    idx, sched = plan_from_columns(st, col)
    try:
        plan = Plan.from_indices(instance, idx, sched)
        return Result.from_plan(instance, "import", objective, plan, status="feasible", runtime_s=0.0,
                                solver={"model": str(model), "solution": str(solution), "columns_read": len(values)})
    except PlanError as e:  # the solution's plan breaks a rule: name the file
        raise PlanError(f"SOLUTION: {solution}: its plan breaks a rule: {e}") from None
