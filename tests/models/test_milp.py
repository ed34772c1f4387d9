"""The MILP arrays: structure, consistency with the simulator, export round trip."""

from __future__ import annotations

import math

import highspy
import numpy as np
import pytest
from conftest import solve_model_file, tiny_instances
from oracles.bruteforce import brute_force

import voiopt
from voiopt.core.plan import Plan
from voiopt.core.simulate import simulate_indices
from voiopt.errors import OptionError
from voiopt.grid import lattice
from voiopt.objectives import better
from voiopt.solvers.milp import export as milp_export
from voiopt.solvers.milp import formulation as milp_formulation
from voiopt.solvers.milp import uploads as milp_uploads
from voiopt.solvers.milp.solution import clean_schedule


def random_plan(inst, rng):
    lat = lattice.build(inst)
    idx = [lat.start]
    for _ in range(inst.horizon - 1):
        nb = lat.neighbors[idx[-1]]
        idx.append(int(rng.choice(nb[nb >= 0])))
    idx = np.array(idx)
    sched = np.full(inst.horizon, -1)
    for t, p in enumerate(idx):
        ok = np.flatnonzero(lat.in_range[:, p])
        if len(ok) and rng.random() < 0.7:
            sched[t] = rng.choice(ok)
    return idx, sched


def solve_highs(model):
    h = highspy.Highs()
    h.silent()
    h.setOptionValue("mip_rel_gap", 0.0)
    h.passModel(model.to_highs_lp())
    h.run()
    assert h.getModelStatus() == highspy.HighsModelStatus.kOptimal
    return h


def test_variables_only_where_they_can_be_one():
    inst = voiopt.generate(3, 8, seed=3)
    lat = lattice.build(inst)
    st = milp_uploads.structure(inst, "voi")
    for t in range(inst.horizon):
        assert ((st.x_col[t] >= 0) == lat.reachable(t)).all()
    assert lat.in_range[st.up_sensor, st.up_point].all()
    assert lat.reachable(0)[st.up_point[st.up_slot == 0]].all()
    for w in st.level_worth:  # worth never falls with the level (the ordering fact)
        for row in w:
            live = row[~np.isnan(row)]
            assert (np.diff(live) >= 0).all()


@pytest.mark.parametrize("objective", list(voiopt.OBJECTIVES))
def test_plan_columns_are_feasible_and_score_the_simulated_value(objective):
    rng = np.random.default_rng(0)
    for inst in tiny_instances(8, seed=99):
        model = milp_formulation.build(inst, objective)
        for _ in range(5):
            idx, sched = random_plan(inst, rng)
            col = model.solution_from_plan(idx, sched)
            act = model.matrix @ col
            assert (act <= model.row_upper + 1e-9).all() and (act >= model.row_lower - 1e-9).all()
            assert (col >= model.col_lower - 1e-12).all() and (col <= model.col_upper + 1e-12).all()
            clean = clean_schedule(model.structure, idx, sched)
            value = simulate_indices(inst, idx, clean).metrics[objective]
            got = model.worth_of_objective(model.cost @ col)
            worth = value if model.structure.kind == "voi" else -value
            assert got == pytest.approx(worth, rel=1e-9)
            # cleaning never lowers the plan's value
            raw = simulate_indices(inst, idx, sched).metrics[objective]
            assert not better(objective, raw, value)


@pytest.mark.parametrize("objective", ["min-voi", "max-aoi"])
def test_single_milp_agrees_with_brute_force(objective):
    """The one-MILP form of the min/max objectives (what export writes) is exact too."""
    for inst in tiny_instances(8, seed=7):
        best, _ = brute_force(inst, objective)
        model = milp_formulation.build(inst, objective)
        h = solve_highs(model)
        idx, sched = model.plan_from_solution(np.asarray(h.getSolution().col_value))
        value = voiopt.evaluate(inst, Plan.from_indices(inst, idx, sched))[objective]
        assert value == pytest.approx(best, rel=1e-6)


@pytest.mark.parametrize("suffix", [".mps", ".lp"])
@pytest.mark.parametrize("objective", list(voiopt.OBJECTIVES))
def test_export_reads_back_with_the_same_optimum(tmp_path, suffix, objective):
    inst = tiny_instances(6, seed=5)[5]
    best, _ = brute_force(inst, objective)
    path = tmp_path / f"model{suffix}"
    milp_export.export(inst, objective, path)
    h = solve_model_file(path)
    assert h.getModelStatus() == highspy.HighsModelStatus.kOptimal
    value = h.getInfo().objective_function_value
    if objective == "min-voi":  # written in log-worths: the objective is ln V (docs/milp.md)
        assert value == pytest.approx(math.log(best), abs=1e-6)
        value = math.exp(value)
    assert value == pytest.approx(best, rel=1e-6)


def test_export_rejects_unknown_format(tmp_path):
    inst = tiny_instances(1)[0]
    with pytest.raises(OptionError, match="use .mps or .lp"):
        milp_export.export(inst, "min-voi", tmp_path / "model.xyz")
    assert not (tmp_path / "model.xyz").exists()


def test_covering_is_none_when_unreachable():
    inst = tiny_instances(1)[0]
    st = milp_uploads.structure(inst, "voi")
    top = st.best_worth()[1:].min()
    assert milp_formulation.build_covering(inst, "min-voi", float(np.nextafter(st.candidates().max(), np.inf))) is None
    assert milp_formulation.build_covering(inst, "min-voi", float(top)) is not None


def test_the_cap_on_a_slots_least_worth_holds_for_every_legal_plan():
    """z_t <= min_worth_cap()[t]: one robot uploads one sensor a slot, so some sensor's best
    upload so far is N slots old (N/K with K robots), or it holds its initial packet. Checked
    against every legal plan the oracle enumerates, for VoI and AoI worths, on tiny networks,
    two-robot fleets and the extreme-worth networks (rho 1e-6, where the cap is a million
    times below the old one: HiGHS then claimed optimal a plan 5e-4 below the optimum)."""
    import json
    from pathlib import Path

    from conftest import fleet_instances
    from oracles import model_oracle as oracle

    from voiopt.core.instance import from_dict
    from voiopt.solvers.milp.uploads import structure

    extreme = json.loads((Path(__file__).resolve().parents[1] / "data" / "milp_extreme_worths.json").read_text())
    nets = [*tiny_instances(12), *fleet_instances(6), *map(from_dict, extreme)]
    tighter = checked = 0
    for inst in nets:
        d = inst.to_dict()
        if oracle.count_legal_plans(d) > 20_000:
            continue
        o = oracle._parse(d)
        caps = {kind: structure(inst, kind).min_worth_cap() for kind in ("voi", "aoi")}
        plain = structure(inst, "voi").best_worth().min(axis=1)
        tighter += bool((caps["voi"][1:] < plain[1:] * (1 - 1e-9)).any())
        for trajs in oracle._iter_trajs(o):
            aoi, q = [s.a0 for s in o.sensors], [s.q0 for s in o.sensors]
            for t in range(inst.horizon):
                ups = {sched[t]: o.distance(pos[t], sched[t]) for pos, sched in trajs if sched[t] is not None}
                for i in range(len(aoi)):
                    aoi[i], q[i] = (1, ups[i]) if i in ups else (aoi[i] + 1, q[i])
                least = min(oracle._voi(o, i, aoi[i], q[i]) for i in range(len(aoi)))
                assert least <= caps["voi"][t + 1] * (1 + 1e-9) + 1e-300, (inst.name, t + 1, trajs)
                assert -max(aoi) <= caps["aoi"][t + 1], (inst.name, t + 1, trajs)
        checked += 1
    assert checked >= 15 and tighter >= 5, (checked, tighter)


def test_the_least_worth_cap_is_computed_once_per_structure(monkeypatch):
    """The model's scale, its level terms and the bisection each computed min_worth_cap again
    (issue 47): now once per Structure, the same read-only array for every caller."""
    inst = voiopt.generate(4, 20, seed=5)
    st = milp_uploads.structure(inst, "voi")
    calls = []
    best = milp_uploads.Structure.best_worth
    monkeypatch.setattr(milp_uploads.Structure, "best_worth", lambda self: calls.append(1) or best(self))
    milp_formulation.default_scale(st, "mean-min-voi")
    milp_formulation.level_terms(st, True)
    first = st.min_worth_cap()
    assert st.min_worth_cap() is first and not first.flags.writeable and len(calls) == 1
