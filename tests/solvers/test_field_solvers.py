"""Every method under the field rules of MODEL.md section 9 (blocked points, an end point, a
move budget): the exact ones equal the independent brute-force oracle on all four objectives,
the others always return legal plans, and Q-learning's kernel equals its plain-Python
statement with the mask."""

from __future__ import annotations

import random

import highspy
import numpy as np
import pytest
from conftest import field_instances, solve_model_file
from oracles import model_oracle as oracle

import voiopt
from voiopt.core.plan import Plan
from voiopt.core.result import OPTIMAL_RTOL
from voiopt.mdp import robot as mdp_mod
from voiopt.objectives import OBJECTIVES
from voiopt.runtime.stop import Stop
from voiopt.solvers.baselines import heuristics as baselines
from voiopt.solvers.milp.export import export
from voiopt.solvers.qlearning.kernels import rollout, train
from voiopt.solvers.qlearning.reference import reference_qlearning
from voiopt.solvers.qlearning.rng import seed_state
from voiopt.solvers.qlearning.table import QTable

CASES = field_instances()
RTOL = 1e-9


@pytest.fixture(scope="module")
def optima():
    """The oracle's optimum of every case and objective."""
    return {(inst.name, obj): oracle.brute_force(inst.to_dict(), obj)[0] for inst in CASES for obj in OBJECTIVES}


def _same(a: float, b: float) -> bool:
    return abs(a - b) <= RTOL * max(abs(a), abs(b), 1e-300)


@pytest.mark.parametrize("method, options", [("milp", {}), ("dp", {}), ("dp", {"fast_budget": 1})],
                         ids=["milp", "dp", "dp-bounded"])
@pytest.mark.parametrize("objective", list(OBJECTIVES))
def test_exact_methods_equal_the_oracle(optima, method, options, objective):
    """dp-bounded skips the unbounded first pass: incumbents, BFS-distance bounds, the moves-left
    dominance lane and the pruning by the way to end all take part."""
    for inst in CASES:
        r = voiopt.solve(inst, method, objective, **options)
        want = optima[inst.name, objective]
        assert r.status == "optimal", (inst.name, r.solver)
        assert _same(r.value, want), (inst.name, r.value, want)
        assert r.bound == pytest.approx(want, rel=OPTIMAL_RTOL)  # a MILP bound carries HiGHS's tolerance
        oracle.simulate(inst.to_dict(), r.plan.to_dict())  # legal in the oracle's eyes too


@pytest.mark.parametrize("objective", list(OBJECTIVES))
def test_milp_survives_a_presolve_fault_on_a_tight_budget(objective):
    """Found by a randomised review: with max_moves equal to the fewest moves to end, HiGHS
    1.16's presolve ended a covering problem of min-voi with a solve error (the model is
    feasible). The MILP solves again with presolve off and proves the optimum dp proves."""
    inst = voiopt.core.instance.from_dict({
        "name": "tight", "area": {"width": 2, "height": 3}, "horizon": 7, "start": [1, 2],
        "sensors": [{"position": [0.24, 2.57], "rho": 0.24, "initial_aoi": 2},
                    {"position": [1.53, 1.83], "rho": 0.27, "initial_aoi": 2},
                    {"position": [1.19, 0.67], "rho": 0.57, "initial_aoi": 4}],
        "blocked": [[1, 1]], "end": [2, 1], "max_moves": 2})
    r, exact = voiopt.solve(inst, "milp", objective), voiopt.solve(inst, "dp", objective)
    assert r.status == exact.status == "optimal"
    assert _same(r.value, exact.value)


def test_moves_field_holds_a_move_in_the_last_slot():
    """The moves made reach budget + 1 after a move in the last slot: the packed field holds it."""
    for inst in CASES:
        model = mdp_mod.build(inst)
        if model.moves_in_state:
            state = (*model.initial_state()[:4], model.budget + 1)
            assert model.decode(model.encode(state)) == state


def test_unservable_sensors_count_blocked_points():
    d = {"area": {"width": 2, "height": 2}, "horizon": 3, "start": [0, 0], "channel": {"d_th": 0.5},
         "sensors": [{"position": [1, 1], "rho": 0.5}, {"position": [2, 2], "rho": 0.5}], "blocked": [[1, 1]]}
    assert voiopt.grid.lattice.unservable_sensors(voiopt.core.instance.from_dict(d)) == [0]


@pytest.mark.parametrize("objective", ["mean-min-voi", "max-aoi"])
def test_exported_model_carries_the_fields(tmp_path, optima, objective):
    budgeted = [c for c in CASES if c.max_moves is not None and c.max_moves < c.horizon - 1][:3]
    ended = [c for c in CASES if c.end is not None and c.blocked][:3]
    assert budgeted and ended
    for inst in budgeted + ended:
        path = tmp_path / f"{inst.name}.mps"
        export(inst, objective, path)
        h = solve_model_file(path)
        assert h.getModelStatus() == highspy.HighsModelStatus.kOptimal
        assert h.getInfo().objective_function_value == pytest.approx(optima[inst.name, objective], rel=1e-6)


@pytest.mark.parametrize("method", ["greedy", "shortest-path", "qlearning", "aoi-qlearning", "beam"])
def test_other_methods_return_legal_plans(method):
    options = {"episodes": 3000} if "qlearning" in method else {}
    for inst in CASES:
        for objective in ("mean-min-voi", "max-aoi"):
            r = voiopt.solve(inst, method, objective, **options)  # Result.from_plan rejects illegal plans
            oracle.simulate(inst.to_dict(), r.plan.to_dict())


@pytest.mark.parametrize("heuristic", [baselines._greedy, baselines._shortest_path])
def test_heuristics_stopped_at_once_still_reach_end(heuristic):
    ended = [c for c in CASES if c.end is not None]
    for inst in ended:
        stop = Stop()
        stop.request()
        r = heuristic(inst, "mean-min-voi", stop) if heuristic is baselines._greedy else heuristic(
            inst, "mean-min-voi", stop, 0)
        oracle.simulate(inst.to_dict(), r.plan.to_dict())


@pytest.mark.parametrize("reward", ["voi", "aoi"])
def test_masked_kernel_equals_the_reference(reward):
    masked = [c for c in CASES if mdp_mod.build(c).masked]
    assert len(masked) >= 10
    for inst in masked:
        model = mdp_mod.build(inst, reward)
        episodes = 400
        q, idx, sched = reference_qlearning(model, episodes, seed=5)
        table = QTable(model, 0.0, None)
        train(model, table, episodes, np.array([1.0]), 1.0 / episodes, 0.75, 0.9,
              np.array([seed_state(5)], dtype=np.uint64))
        got_idx, got_sched = rollout(model, table)
        assert got_idx.tolist() == idx and got_sched.tolist() == sched
        assert table.to_dict() == q
        voiopt.evaluate(inst, Plan.from_indices(inst, got_idx, got_sched))


def test_moves_join_the_state_only_with_a_binding_budget():
    for inst in CASES:
        model = mdp_mod.build(inst)
        binding = inst.max_moves is not None and inst.max_moves < inst.horizon - 1
        assert model.moves_in_state == binding
        assert model.masked == (binding or inst.end is not None)


def test_env_masks_and_rollouts_are_legal():
    gym = pytest.importorskip("gymnasium")  # the [rl] extra, installed by the test extras
    import voiopt.env  # noqa: F401

    rng = random.Random(1)
    for inst in CASES:
        env = gym.make(voiopt.env.ENV_ID, instance=inst, infeasible="penalise").unwrapped
        for masked_only in (True, False):
            env.reset(seed=0)
            for _t in range(inst.horizon):
                mask = env.action_masks()
                assert mask.any()
                choices = np.flatnonzero(mask) if masked_only else np.arange(len(mask))
                a = int(rng.choice(choices.tolist()))
                _, _, _, _, info = env.step(a)
                assert info["infeasible"] == (not mask[a])
            oracle.simulate(inst.to_dict(), env.plan().to_dict())  # every rollout is a legal plan
