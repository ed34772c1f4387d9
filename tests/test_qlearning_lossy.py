"""Q-learning on lossy links (MODEL.md sections 7 and 11): it learns from sampled outcomes and
returns its greedy policy, valued exactly on tiny instances, never above the optimal policy;
with every probability 1 it is bit for bit the lossless Q-learning."""

from __future__ import annotations

import pytest
from oracles.expectimax import oracle, tiny

import voiopt
from voiopt.core import policy_value
from voiopt.core.instance import from_dict
from voiopt.core.policy import Policy
from voiopt.core.policy_value import exact_value
from voiopt.networks.generate import generate
from voiopt.runtime.stop import INTERRUPTED, TIME_LIMIT, Stop, Stopped, watch
from voiopt.solvers.qlearning import lossy


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


def test_a_stop_asked_before_the_run_stops_every_step_and_still_values_the_policy():
    """A Ctrl-C that came before (a watch outside, already stopped): training stops after its
    first chunk, the evaluation after the two scenarios a CI needs, the bound's dp at once;
    the status says interrupted, the value is a labelled Monte Carlo estimate."""
    inst = from_dict(tiny(3, 3, 6, {"model": "bernoulli", "success": 0.6}))
    with watch() as outer:
        outer.request(INTERRUPTED)
        r = voiopt.solve(inst, "qlearning", episodes=10**8, seed=0, samples=500)
    assert r.status == "interrupted" and 0 < r.solver["episodes_run"] < 10**8
    assert r.evaluation == "monte-carlo" and r.samples == policy_value.MIN_SCENARIOS
    assert r.value_ci[0] <= r.value <= r.value_ci[1]
    assert "interrupted" in r.solver["stopped"] and "over 2 of 500 scenarios" in r.solver["stopped"]
    assert r.bound_kind == "lossless" and r.value <= r.bound  # the stopped dp's bound is still proven
    assert r.bound >= oracle(tiny(3, 3, 6, {"model": "bernoulli", "success": 0.6}), "mean-min-voi") * (1 - 1e-9)


def test_a_time_limit_cuts_the_monte_carlo_value_short_and_says_over_how_many_scenarios(monkeypatch):
    """The Monte Carlo value after training honours the time limit: an estimate over the
    scenarios done (20,000 of 1 ms each cannot fit in the step's time), with its count."""
    monkeypatch.setattr(lossy, "EXACT_STATES", 0)  # no exact value: Monte Carlo
    inst = from_dict(generate(5, 20, width=3.0, height=3.0, seed=4).to_dict()
                     | {"links": {"model": "bernoulli", "success": 0.7}})
    r = voiopt.solve(inst, "qlearning", episodes=10**8, seed=0, samples=20_000, time_limit=0.2)
    assert r.status == "time_limit" and r.evaluation == "monte-carlo"
    assert policy_value.MIN_SCENARIOS <= r.samples < 20_000 and r.value_ci[0] <= r.value <= r.value_ci[1]
    assert f"over {r.samples} of 20000 scenarios" in r.solver["stopped"] and "Monte Carlo stopped" in r.solver["stopped"]
    assert r.bound_kind == "lossless" and r.value <= r.bound
    assert r.runtime_s < 0.2 + 30  # a coarse sanity bound: without the stop rule, 20,000 runs take a minute


def test_the_exact_enumeration_stops_when_the_rule_says_stop():
    inst = from_dict(tiny(3, 3, 6, {"model": "bernoulli", "success": 0.6}))
    policy = Policy(inst, "mean-min-voi", "replan", plan=voiopt.solve(inst, "dp").plan)
    stop = Stop()
    assert exact_value(policy, stop=stop) == exact_value(policy)  # not asked: the same value
    stop.request(TIME_LIMIT)
    with pytest.raises(Stopped):
        exact_value(policy, stop=stop)
