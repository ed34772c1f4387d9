"""The exact MILP for several robots (MODEL.md section 10, issue #14): agreement with the
independent oracle's brute force, rules between robots that really bind, time limits, Ctrl-C,
warm starts, a fleet with no legal plan, the CLI and the exported model."""

from __future__ import annotations

import json
import math

import highspy
import numpy as np
import pytest
from conftest import fleet_instances, sigint_after, solve_model_file, stop_at_check, undecided
from oracles import model_oracle as oracle

import voiopt
from voiopt.cli.main import main
from voiopt.core.instance import from_dict
from voiopt.core.plan import FleetPlan, Plan
from voiopt.core.simulate import check_plan, simulate_indices
from voiopt.errors import PlanError
from voiopt.solvers import FLEET
from voiopt.solvers.milp import formulation as milp_formulation
from voiopt.solvers.milp import model as milp_model
from voiopt.solvers.milp.solver import solve

CASES = fleet_instances()
OBJECTIVES = list(voiopt.OBJECTIVES)


@pytest.fixture(scope="module")
def optima():
    """(case, objective) -> the oracle's brute-force optimum and one optimal plan."""
    return {(inst.name, ob): oracle.brute_force(inst.to_dict(), ob) for inst in CASES for ob in OBJECTIVES}


def two_robots(inst: voiopt.Instance) -> voiopt.Instance:
    """A one-robot network with a second robot at the point opposite its start."""
    d = inst.to_dict()
    s = d.pop("start")
    d["robots"] = [{"start": s}, {"start": [inst.width - s[0], inst.height - s[1]]}]
    return from_dict(d)


@pytest.fixture(scope="module")
def larger():
    return two_robots(voiopt.generate(8, 20, seed=1, name="fleet-larger"))


def test_milp_plans_for_fleets():
    assert "milp" in FLEET


@pytest.mark.parametrize("objective", OBJECTIVES)
def test_agrees_with_the_oracle_on_every_fleet_case(objective, optima):
    for inst in CASES:
        best, _ = optima[inst.name, objective]
        r = solve(inst, objective)
        assert r.status == "optimal", (inst.name, r.solver)
        assert r.value == pytest.approx(best, rel=1e-9, abs=0), inst.name
        assert len(r.plan.robots) == 2
        assert voiopt.evaluate(inst, r.plan)[objective] == r.value


def _without_rows(model: milp_model.Model, prefix: str) -> milp_model.Model:
    """The model with the rows of one block dropped (a relaxation)."""
    keep = np.array([not n.startswith(prefix) for n in model.row_names()])
    model.matrix = model.matrix.tocsr()[keep].tocsc()
    model.row_lower, model.row_upper, model.row_blocks = model.row_lower[keep], model.row_upper[keep], ()
    return model


def test_the_rules_between_robots_bind(optima):
    """Robot 1 changes the optimum (robot 0 alone does worse in many cases), and without the
    swap rows the model finds strictly better plans that swap: the swap rule binds, and the
    MILP (previous test) still meets the oracle's optimum there."""
    alone_differs = swap_binds = 0
    for inst in CASES:
        d = inst.to_dict()
        d["robots"] = d["robots"][:1]
        for ob in OBJECTIVES:
            best, _ = optima[inst.name, ob]
            alone_differs += oracle.brute_force(d, ob)[0] != pytest.approx(best, rel=1e-9)
            model = _without_rows(milp_formulation.build(inst, ob), "swap")
            h = milp_model.new_highs()
            h.silent()
            h.setOptionValue("mip_rel_gap", 0.0)
            h.passModel(model.to_highs_lp())
            h.run()
            idx, sched = model.plan_from_solution(np.asarray(h.getSolution().col_value))
            relaxed = simulate_indices(inst, idx, sched).metrics[ob]
            if voiopt.objectives.better(ob, relaxed, best) and relaxed != pytest.approx(best, rel=1e-9):
                swap_binds += 1
                with pytest.raises(PlanError, match="swap"):
                    check_plan(inst, Plan.from_indices(inst, idx, sched))
    assert alone_differs >= 10
    assert swap_binds >= 1


def test_a_fleet_whose_ends_need_a_swap_is_infeasible(tmp_path, capsys):
    d = {"name": "swap", "area": {"width": 1, "height": 0.5}, "horizon": 3,
         "robots": [{"start": [0, 0], "end": [1, 0]}, {"start": [1, 0], "end": [0, 0]}],
         "sensors": [{"position": [0.5, 0.2], "rho": 0.5}]}
    inst = undecided(d)  # past the loader's check of joint plans, HiGHS proves there is none
    for ob in ("min-voi", "mean-max-aoi"):
        r = solve(inst, ob)
        assert r.status == "infeasible" and r.plan is None and r.value is None
        assert "no legal joint plan" in r.solver["note"]
    path = tmp_path / "swap.json"
    path.write_text(json.dumps(d))
    assert main(["solve", str(path), "--method", "milp"]) == 2  # the loader's check decides this one
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "robots: no legal joint plan" in err


def test_warm_start_fleet_plan_is_used_and_checked(optima):
    inst = CASES[0]
    best, plan = optima[inst.name, "min-voi"]
    r = solve(inst, "min-voi", warm_start=Plan.from_dict(plan))
    assert r.status == "optimal" and r.solver["warm_start"] == "given"
    assert r.solver["plan_source"] == "warm start" and r.value == pytest.approx(best, rel=1e-12)
    with pytest.raises(PlanError, match="robots"):
        solve(inst, "min-voi", warm_start=Plan.from_dict(plan["robots"][0]))


@pytest.mark.parametrize("objective", ["mean-min-voi", "max-aoi"])
def test_time_limit_on_a_larger_fleet_returns_a_legal_plan_and_a_valid_bound(larger, objective):
    r = solve(larger, objective, time_limit=2)
    assert r.status in ("time_limit", "optimal")
    assert isinstance(r.plan, FleetPlan) and voiopt.evaluate(larger, r.plan)[objective] == r.value
    assert r.bound is not None
    assert (r.bound >= r.value) if voiopt.objectives.get(objective).maximise else (r.bound <= r.value)
    assert r.runtime_s < 6


def test_ctrl_c_stops_a_fleet_with_its_best_plan_and_bound(larger):
    with sigint_after(1.0):
        r = solve(larger, "mean-max-aoi", time_limit=30)
    assert r.status == "interrupted" and r.solver.get("stopped") == "interrupted by SIGINT"
    assert r.runtime_s < 10 and r.bound <= r.value and isinstance(r.plan, FleetPlan)


def test_cli_solve_evaluate_and_export(tmp_path, capsys, optima):
    inst = CASES[1]
    fleet, out = tmp_path / "fleet.json", tmp_path / "out.json"
    fleet.write_text(json.dumps(inst.to_dict()))
    assert main(["solve", str(fleet), "--method", "milp", "--objective", "min-voi", "--quiet", "-o", str(out)]) == 0
    result = json.loads(out.read_text())
    assert result["status"] == "optimal" and len(result["plan"]["robots"]) == 2
    capsys.readouterr()
    assert main(["evaluate", str(fleet), str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["metrics"] == pytest.approx(result["metrics"], rel=1e-12)
    for ob, suffix in (("min-voi", ".mps"), ("mean-max-aoi", ".lp")):
        model = tmp_path / f"model{suffix}"
        assert main(["export", str(fleet), str(model), "--objective", ob]) == 0
        h = solve_model_file(model)
        assert h.getModelStatus() == highspy.HighsModelStatus.kOptimal
        value = h.getInfo().objective_function_value
        value = math.exp(value) if ob == "min-voi" else value  # min-voi is written as ln V (docs/milp.md)
        assert value == pytest.approx(optima[inst.name, ob][0], rel=1e-6)
        names = h.getLp().col_names_
        for prefix in ("x_r0_t", "x_r1_t", "f_r0_t", "f_r1_t", "o_t", "y_i"):  # docs/milp.md, "Several robots"
            assert any(n.startswith(prefix) for n in names), prefix


def test_three_robots_following_each_other_in_a_line():
    """Each robot moves into the point the next one leaves in the same slot: legal (not a
    swap), and the only way to the ends, so the flow rows must allow it."""
    d = voiopt.generate(3, 2, width=2.0, height=1.0, seed=5, name="line").to_dict()
    del d["start"]
    d["robots"] = [{"start": [0, 0], "end": [1, 0]}, {"start": [1, 0], "end": [2, 0]}, {"start": [2, 0], "end": [2, 1]}]
    inst = from_dict(d)
    for ob in OBJECTIVES:
        r = solve(inst, ob)
        assert r.status == "optimal" and len(r.plan.robots) == 3
        assert r.value == pytest.approx(oracle.brute_force(d, ob)[0], rel=1e-9, abs=0)


def test_one_robot_readers_of_the_model_refuse_a_fleet(tmp_path):
    from voiopt.errors import OptionError
    from voiopt.solvers.milp import pyomo as pyomo_model
    from voiopt.solvers.milp.solution_file import import_solution

    with pytest.raises(OptionError, match="2 robots"):
        pyomo_model.build(CASES[0], "min-voi")
    with pytest.raises(OptionError, match="2 robots"):
        import_solution(CASES[0], "min-voi", tmp_path / "m.mps", tmp_path / "s.sol")


def test_a_solve_stopped_by_its_time_limit_says_so():
    """With 1 ms the greedy warm start is cut short and HiGHS, stopped, proves the optimum
    without handing over its plan: the status is time_limit (it was "feasible"), with the
    proven bound; given time, the same network is solved to optimality."""
    inst = from_dict({"name": "g21-41", "area": {"width": 2.0, "height": 1.0}, "horizon": 3,
                      "channel": {"d_th": 0.5},
                      "sensors": [{"position": [0.851089, 0.936624], "rho": 0.999999, "power_w": 0.1},
                                  {"position": [0.934365, 0.028558], "rho": 0.91905, "power_w": 0.1},
                                  {"position": [0.950467, 0.29038], "rho": 0.012972}],
                      "robots": [{"start": [2.0, 1.0], "max_moves": 2}, {"start": [1.0, 1.0], "end": [1.0, 0.0]}]})
    full = solve(inst, "mean-min-voi")
    assert full.status == "optimal"
    for limit in (0.001, 0.01):
        r = solve(inst, "mean-min-voi", time_limit=limit)
        assert r.status in ("time_limit", "optimal"), (limit, r.status, r.solver.get("stopped"))
        assert r.status == "optimal" or r.solver["stopped"].startswith("time limit")
        assert r.bound >= full.value * (1 - 1e-9)


def test_stopped_while_greedy_walks_milp_does_not_go_on_to_the_repair(monkeypatch):
    """A fleet milp's warm start is greedy's joint plan, else each robot's greedy plan, else
    their repair by HiGHS on the path model. Greedy gets the time left; when it was stopped and
    its walk gave up, milp still went on to each robot's greedy and built the path model
    (3.35 to 3.9 s for a 1.81 s limit at T = 1881, four robots, a fuzz campaign). Now it stops
    there, with status time_limit (the limit that stopped it; issue 47: it said error), and no plan, saying why."""
    from voiopt.solvers.baselines import fleet as fleet_baselines

    monkeypatch.setattr(fleet_baselines, "MAX_TRIES_STOPPED", -1)  # a stopped walk not home gives up
    monkeypatch.setattr(fleet_baselines, "_legal_paths", lambda *a: None)  # and has no exact fallback
    monkeypatch.setattr(milp_formulation, "build_covering", lambda *a, **k: pytest.fail("the path model was built"))
    stop_at_check(monkeypatch, 12)
    d = {"name": "conflict", "area": {"width": 3, "height": 3}, "horizon": 12,  # each robot's greedy plan
         "robots": [{"start": [0, 0], "end": [2, 0]}, {"start": [1, 0], "end": [0, 0]},  # swaps with another's
                    {"start": [2, 0], "end": [1, 0]}],
         "sensors": [{"position": [1.5, 3], "rho": 0.3}]}
    r = solve(from_dict(d), "mean-min-voi")
    assert r.status == "time_limit" and r.plan is None, r.solver
    assert r.solver["warm_start"].endswith("stopped before the repair")
    assert "greedy: the conflict-free walker gave up" in r.solver["note"]
