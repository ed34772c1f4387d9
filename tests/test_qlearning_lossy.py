"""Q-learning on lossy links (MODEL.md sections 7 and 11): it learns from sampled outcomes and
returns its greedy policy, valued exactly on tiny instances, never above the optimal policy;
with every probability 1 it is bit for bit the lossless Q-learning."""

from __future__ import annotations

import pytest
from oracles.expectimax import oracle, tiny

import voiopt
from voiopt.core.instance import from_dict
from voiopt.core.policy import Policy
from voiopt.core.policy_value import exact_value


@pytest.mark.parametrize(("method", "objective"), [("qlearning", "mean-min-voi"), ("aoi-qlearning", "mean-max-aoi")])
def test_lossy_qlearning_policy_is_valued_and_bounded(method, objective, tmp_path):
    d = tiny(3, 2, 5, {"model": "bernoulli", "success": 0.5})
    inst = from_dict(d)
    r = voiopt.solve(inst, method, objective, episodes=3000, seed=2)
    best = oracle(d, objective)
    assert r.status == "feasible" and r.evaluation == "exact" and r.bound_kind == "lossless"
    maximise = objective == "mean-min-voi"
    assert (r.value <= best * (1 + 1e-9) <= r.bound * (1 + 1e-9)) if maximise else (r.value >= best * (1 - 1e-9) >= r.bound * (1 - 1e-9))
    assert r.solver["decisions"]["from_table"] > 0
    again = voiopt.solve(inst, method, objective, episodes=3000, seed=2)
    assert again.value == r.value and again.solver["table_states"] == r.solver["table_states"]
    r.policy.save(tmp_path / "q.json")
    assert exact_value(Policy.load(tmp_path / "q.json"), objective) == pytest.approx(r.value, rel=1e-12)


def test_outcomes_change_what_is_learnt():
    d = tiny(3, 2, 5, {"model": "bernoulli", "success": 0.3})
    lossy = voiopt.solve(from_dict(d), "qlearning", episodes=2000, seed=0)
    plain = voiopt.solve(from_dict({k: v for k, v in d.items() if k != "links"}), "qlearning", episodes=2000, seed=0)
    assert lossy.solver["table_states"] != plain.solver["table_states"]


@pytest.mark.parametrize("method", ["qlearning", "aoi-qlearning"])
def test_success_one_is_bit_for_bit_lossless(method):
    d = tiny(5, 3, 6, None)
    plain = voiopt.solve(from_dict(d), method, episodes=3000, seed=4)
    ones = voiopt.solve(from_dict(d | {"links": {"model": "bernoulli", "success": 1.0}}), method, episodes=3000, seed=4)
    assert ones.plan == plain.plan and ones.value == plain.value and ones.metrics == plain.metrics
    assert ones.solver["table_states"] == plain.solver["table_states"] and ones.evaluation is None


def test_lossy_qlearning_stopped_by_the_time_limit_reports_its_policy_so_far():
    inst = from_dict(tiny(3, 2, 5, {"model": "bernoulli", "success": 0.5}))
    r = voiopt.solve(inst, "qlearning", episodes=10**8, seed=0, time_limit=1e-6)
    assert r.status == "time_limit" and 0 < r.solver["episodes_run"] < 10**8
    assert r.evaluation == "exact" and r.value <= r.bound
