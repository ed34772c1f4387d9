"""Read an external MILP solver's solution back into a plan (``voiopt import-solution``).

The solution is matched to the exported model by column name (docs/milp.md): only the x and y
columns matter, ``x_t<slot>_p<point>`` and ``y_i<sensor>_t<slot>_p<point>``. Two file forms
are read: HiGHS's solution file (``writeSolution``, or ``--solution_file``), the common
``name value`` lines of a .sol file from SCIP or Gurobi, and CPLEX's XML; other lines (headers,
comments, rows) are skipped, and a column a file leaves out is 0. A file cut short is refused:
its header's count of columns (HiGHS), or the objective value it states against the one its
values give under the model. The plan is then simulated like any other: the file's own
objective value is never used as the result's.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation
from pathlib import Path

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.plan import Plan
from voiopt.core.result import Result
from voiopt.errors import OptionError, PlanError
from voiopt.runtime.files import MAX_JSON_BYTES
from voiopt.solvers.milp.model import new_highs, path_names, worth_name
from voiopt.solvers.milp.solution import plan_from_columns
from voiopt.solvers.milp.uploads import structure


def _existing(path: str | os.PathLike, what: str) -> Path:
    """The file ``path``; an OptionError naming ``what`` if it is missing or a folder."""
    p = Path(path)
    if not p.is_file():
        raise OptionError(f"{what}: {path}: {'a folder, not a file' if p.is_dir() else 'no such file'}")
    return p


@dataclass(frozen=True)
class Model:
    """What import needs of an MPS or LP file: its column names, its sense and its objective."""

    names: set[str]
    maximises: bool
    cost: dict[str, float]  # the non-zero objective coefficients
    offset: float


def read_model(model: str | os.PathLike) -> Model:
    """An MPS or LP file, read by HiGHS."""
    import highspy

    h = new_highs()
    h.silent()
    _existing(model, "MODEL")
    if h.readModel(str(model)) == highspy.HighsStatus.kError:
        raise OptionError(f"MODEL: HiGHS cannot read {str(model)!r} as MPS or LP")
    lp = h.getLp()
    cost = {n: float(c) for n, c in zip(lp.col_names_, lp.col_cost_, strict=True) if c != 0}
    return Model(set(lp.col_names_), lp.sense_ == highspy.ObjSense.kMaximize, cost, float(lp.offset_))


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


@dataclass
class Read:
    """A solution file's column values (of the model's columns), the objective value it states
    (None if none), and, for HiGHS's file, the columns its header announces and those listed."""

    values: dict[str, float] = field(default_factory=dict)
    stated: float | None = None
    declared: int | None = None
    listed: int = 0  # of the model's columns, under HiGHS's "# Columns" header
    seen: int = 0  # of all the columns under it
    foreign: str | None = None  # the first column name that MODEL has not
    rounding: dict[str, float] = field(default_factory=dict)  # half a unit of each value's last printed digit
    stated_rounding: float = 0.0


_OBJECTIVE = re.compile(r"^#?\s*objective(?:\s+value)?\s*[:=]?\s+(\S+)$", re.IGNORECASE)  # HiGHS, SCIP, Gurobi
_COLUMN = re.compile(r"^[xy]_(?:i\d+_)?t\d+_p\d+$")  # a path column's name, of this instance or not


def read_values(solution: str | os.PathLike, in_model: set[str]) -> Read:
    """The model's columns' values in a solution file: HiGHS's raw file (its primal part),
    ``name value`` lines (SCIP, Gurobi) or CPLEX's XML. A path column the model has not, or a
    column given twice, is refused: the file is of another model, or garbled."""
    p = _existing(solution, "SOLUTION")
    if p.stat().st_size > 8 * MAX_JSON_BYTES:
        raise OptionError(f"SOLUTION: {solution}: larger than {8 * MAX_JSON_BYTES} bytes")
    with open(p, "rb") as f:
        xml = f.read(1024).lstrip().startswith(b"<")
    return _read_xml(p, in_model) if xml else _read_lines(p, in_model)


def _read_xml(p: Path, in_model: set[str]) -> Read:
    """CPLEX's XML: ``<header ... objectiveValue="..."/>`` and ``<variable name= value=/>``,
    attributes on one line or on several."""
    from xml.etree.ElementTree import ParseError, iterparse

    out = Read()
    try:
        for _, element in iterparse(p, events=("end",)):
            if element.tag == "header" and "objectiveValue" in element.attrib:
                out.stated = _number(element.attrib["objectiveValue"], "objectiveValue")
                out.stated_rounding = _half_unit(element.attrib["objectiveValue"])
            elif element.tag == "variable" and "name" in element.attrib and "value" in element.attrib:
                _take(out, element.attrib["name"], element.attrib["value"], in_model, None)
            element.clear()
    except ParseError as e:
        raise OptionError(f"SOLUTION: {p}: not well-formed XML ({e})") from None
    return out


def _read_lines(p: Path, in_model: set[str]) -> Read:
    """HiGHS's raw file, or ``name value`` lines (SCIP, Gurobi)."""
    out, section = Read(), None
    with open(p, encoding="utf-8", errors="replace") as f:
        for line in f:
            text = line.strip()
            if text.startswith(("# Dual", "# Basis")):  # HiGHS: the primal values are all read
                break
            if text.startswith("# Rows"):
                section = "rows"
                continue
            if text.startswith("# Columns"):
                section, words = "columns", text.split()
                out.declared = int(words[2]) if len(words) > 2 and words[2].isdigit() else None
                continue
            found = _OBJECTIVE.match(text)
            if found and section is None:
                out.stated = _number(found.group(1), "objective value", strict=False)
                out.stated_rounding = _half_unit(found.group(1))
                continue
            parts = text.split()
            if len(parts) >= 2 and section != "rows":
                _take(out, parts[0], parts[1], in_model, section)
    return out


def _take(out: Read, name: str, value: str, in_model: set[str], section) -> None:
    out.seen += section == "columns"
    if name not in in_model:
        if _COLUMN.match(name):
            raise OptionError(f"SOLUTION: {name}: not a column of MODEL (a solution of another instance's model?)")
        if section == "columns":
            out.foreign = out.foreign or name
        return
    if name in out.values:
        raise OptionError(f"SOLUTION: {name}: given twice")
    out.values[name] = _number(value, name)
    out.rounding[name] = _half_unit(value)
    out.listed += section == "columns"


def _half_unit(text: str) -> float:
    """Half a unit in the last digit ``text`` prints: how far the value it was printed from may
    lie (0.5 for "1", 5e-07 for "0.123457", 5 for "1.23457e+06")."""
    try:
        exponent = Decimal(text.strip()).as_tuple().exponent
    except InvalidOperation:
        return 0.0
    return 0.5 * 10.0 ** exponent if isinstance(exponent, int) else 0.0


def _number(text: str, what: str, strict: bool = True) -> float | None:
    try:
        v = float(text)
    except ValueError:
        if not strict:
            return None
        raise OptionError(f"SOLUTION: {what}: must be a number, got {text[:40]!r}") from None
    if not np.isfinite(v):
        raise OptionError(f"SOLUTION: {what}: must be a finite number, got {text[:40]!r}")
    return v


def _check_whole(read: Read, model: Model, solution) -> None:
    """A file cut short lists fewer columns than its header says, or states an objective value
    that its values do not give (a column left out counts 0, as in SCIP's files)."""
    if read.declared is not None and read.seen == read.declared and read.listed != read.declared:
        raise OptionError(f"SOLUTION: {solution}: {read.declared - read.listed} of its {read.declared} columns are not "
                          f"MODEL's (such as {read.foreign!r}): a solution of another model (another --objective, "
                          "--covering-level or instance)?")
    if read.declared is not None and read.listed != read.declared:
        raise OptionError(f"SOLUTION: {solution}: its header announces {read.declared} columns, but {read.seen} "
                          "follow: is the file cut short?")
    if read.stated is not None:  # within what the printed digits allow, and a hair for the sums
        terms = [c * read.values.get(n, 0.0) for n, c in model.cost.items()]
        given = model.offset + math.fsum(terms)
        scale = max(abs(read.stated), math.fsum(abs(t) for t in terms), 1e-300)
        printed = read.stated_rounding + math.fsum(abs(c) * read.rounding.get(n, 0.0) for n, c in model.cost.items())
        if abs(given - read.stated) > printed + OBJECTIVE_RTOL * scale:
            raise OptionError(f"SOLUTION: {solution}: states the objective value {read.stated:.10g}, but its columns "
                              f"give {given:.10g} under MODEL: is the file cut short, or of another model?")


OBJECTIVE_RTOL = 1e-7  # beyond the printed digits' rounding: the solver's own sums against ours


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
    m = read_model(model)
    missing = sorted(set(names) - m.names)
    extra = sorted(n for n in m.names - set(names) if _COLUMN.match(n))
    if missing or extra:
        which = f"no {missing[0]}" if missing else f"{extra[0]}, which {instance.name} has not"
        raise OptionError(f"MODEL: its columns are not those voiopt exports for {instance.name} ({which}): "
                          "was it exported from another instance?")
    _check_objective(objective, m.names, m.maximises, instance.horizon)
    read = read_values(solution, m.names)
    values = {k: v for k, v in read.values.items() if k in names}
    if not any(k.startswith("x_") for k in values):
        raise OptionError(f"SOLUTION: {solution}: no value of an x_t<slot>_p<point> column of the model: no primal "
                          "solution in it (HiGHS: write it in the raw style, writeSolution(file, 0))")
    _check_whole(read, m, solution)
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
