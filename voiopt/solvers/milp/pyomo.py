"""The MILP of voiopt.solvers.milp written algebraically in Pyomo (the ``[pyomo]`` extra).

Same variables, same lookup values, same constraints as the array model, so any Pyomo solver
(HiGHS through ``appsi_highs``, Gurobi, CPLEX, SCIP, CBC) can solve it. The objective is in the
objective's own units and sense: mean or minimum VoI in bit/s maximised, mean or maximum AoI
minimised.

    from voiopt.solvers.milp.pyomo import build
    m = build(instance, objective)
    pyo.SolverFactory("appsi_highs").solve(m)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.errors import MissingExtraError, OptionError
from voiopt.grid import lattice as lattice_mod
from voiopt.solvers.milp import formulation as milp_formulation
from voiopt.solvers.milp import uploads as milp_uploads
from voiopt.solvers.milp.solution import plan_from_columns


def build(instance: Instance, objective: str, *, scale: float | None = None) -> Any:
    """A ``pyomo.environ.ConcreteModel`` of the MILP; ``model.scale`` is the worth unit of z.
    One robot only: a fleet's model is the array model's (``voiopt export`` writes it)."""
    if instance.fleet:
        raise OptionError(f"pyomo model: plans for one robot, but {instance.name} has {instance.n_robots} robots "
                          "(export the fleet MILP with voiopt export instead)")
    try:
        import pyomo.environ as pyo
    except ImportError:
        raise MissingExtraError("pyomo", "pyomo") from None

    kind = objectives.get(objective).worth
    st = milp_uploads.structure(instance, kind)
    lat = lattice_mod.build(instance)
    T = st.horizon
    per_slot = objectives.get(objective).per_slot
    scale = float(scale) if scale is not None else milp_formulation.default_scale(st, objective)
    lt = milp_formulation.level_terms(st, per_slot)
    slots_z = list(range(1, T + 1)) if per_slot else [0]

    m = pyo.ConcreteModel(name=f"voiopt {instance.name} {objective}")
    m.scale = scale
    stands = [(int(p), int(t)) for t, p in zip(*np.nonzero(st.x_col >= 0), strict=True)]
    m.X = pyo.Set(initialize=stands, dimen=2)  # (point, slot) reachable from the start
    m.U = pyo.Set(initialize=range(st.n_uploads))  # uploads (sensor, slot, point)
    m.E = pyo.Set(initialize=range(len(lt.sensor)))  # levels (sensor, slot, level)
    m.Z = pyo.Set(initialize=slots_z)

    m.x = pyo.Var(m.X, domain=pyo.Binary)
    m.y = pyo.Var(m.U, domain=pyo.Binary)
    m.H = pyo.Var(m.E, bounds=(0, 1))
    zb = {k: (lt.floor[j] / scale, lt.cap[j] / scale) for j, k in enumerate(slots_z)}
    m.z = pyo.Var(m.Z, bounds=lambda m, k: zb[k])
    m.x[int(lat.start), 0].fix(1)

    def one_point(m, t):
        return sum(m.x[p, t] for p in np.flatnonzero(st.x_col[t] >= 0)) == 1

    m.one_point = pyo.Constraint(range(T), rule=one_point)

    def move(m, p, t):
        if t == 0:
            return pyo.Constraint.Skip
        nb = [int(q) for q in lat.neighbors[p] if q >= 0 and st.x_col[t - 1, q] >= 0]
        return m.x[p, t] <= sum(m.x[q, t - 1] for q in nb)

    m.move = pyo.Constraint(m.X, rule=move)

    at: dict[tuple[int, int], list[int]] = {}
    for u in range(st.n_uploads):
        at.setdefault((int(st.up_point[u]), int(st.up_slot[u])), []).append(u)

    def tdma(m, p, t):
        if (p, t) not in at:
            return pyo.Constraint.Skip
        return sum(m.y[u] for u in at[p, t]) <= m.x[p, t]

    m.tdma = pyo.Constraint(m.X, rule=tdma)

    if st.min_stays:  # max_moves (MODEL.md section 9): enough slots without a move
        stays = list(zip(st.stay_point.tolist(), st.stay_slot.tolist(), strict=True))
        m.S = pyo.Set(initialize=stays, dimen=2)
        m.s = pyo.Var(m.S, bounds=(0, 1))
        m.stay_before = pyo.Constraint(m.S, rule=lambda m, p, t: m.s[p, t] <= m.x[p, t - 1])
        m.stay_after = pyo.Constraint(m.S, rule=lambda m, p, t: m.s[p, t] <= m.x[p, t])
        m.max_moves = pyo.Constraint(expr=sum(m.s[k] for k in m.S) >= st.min_stays)

    eu, uu = lt.uploads(st)
    feeds: dict[int, list[int]] = {}
    for e, u in zip(eu, uu, strict=True):
        feeds.setdefault(int(e), []).append(int(u))

    def level(m, e):
        prev = m.H[int(lt.previous[e])] if lt.previous[e] >= 0 else 0
        return m.H[e] <= prev + sum(m.y[u] for u in feeds.get(e, []))

    m.level = pyo.Constraint(m.E, rule=level)

    terms: dict[tuple[int, int], list[int]] = {}
    for e in range(len(lt.sensor)):
        terms.setdefault((int(lt.sensor[e]), int(lt.slot[e])), []).append(e)
    zi, zt = lt.worth_rows

    def worth(m, i, t):
        k = t if per_slot else 0
        w0 = st.worth0[t, i] / scale
        return m.z[k] <= w0 + sum(lt.increment[e] / scale * m.H[e] for e in terms.get((i, t), []))

    m.worth = pyo.Constraint([(int(i), int(t)) for i, t in zip(zi, zt, strict=True)], rule=worth)

    mean_z = sum(m.z[k] for k in slots_z) / len(slots_z)
    if kind == "voi":
        m.objective = pyo.Objective(expr=scale * mean_z, sense=pyo.maximize)
    else:
        m.objective = pyo.Objective(expr=-scale * mean_z, sense=pyo.minimize)
    return m


def plan_indices(m: Any, instance: Instance, objective: str) -> tuple[np.ndarray, np.ndarray]:
    """(point indices, schedule with -1) of a solved model, uploads cleaned as in the array model."""
    st = milp_uploads.structure(instance, objectives.get(objective).worth)
    col = np.zeros(st.n_base)
    for (p, t), var in m.x.items():
        col[st.x_col[t, p]] = var.value or 0.0
    for u, var in m.y.items():
        col[st.up_col[u]] = var.value or 0.0
    return plan_from_columns(st, col)
