"""Any policy given as a function (voiopt.policy_from_function, voiopt.evaluate_function):
valued like voiopt's own policies, exactly or by Monte Carlo over the same coupled scenarios,
and refused in one line when its action is illegal."""

from __future__ import annotations

import pytest
from oracles.expectimax import oracle, tiny

import voiopt
from voiopt.core.instance import from_dict
from voiopt.core.policy import Policy
from voiopt.core.policy_value import exact_value, monte_carlo_value
from voiopt.core.result import BoundKind, Evaluation
from voiopt.core.scenarios import sample_scenarios
from voiopt.errors import OptionError


def _lossy(seed=1, n=3, T=5, p=0.5):
    return from_dict(tiny(seed, n, T, {"model": "bernoulli", "success": p}))


@pytest.mark.parametrize("objective", ["mean-min-voi", "mean-max-aoi"])
def test_policy_dps_own_act_as_a_function_has_policy_dps_exact_value(objective):
    inst = _lossy(seed=3)
    best = voiopt.solve(inst, "policy-dp", objective)
    asked = []

    def act(observation):
        asked.append(observation)
        return best.policy.act(observation)

    r = voiopt.evaluate_function(inst, objective, act, bound=best.bound, bound_kind=BoundKind.EXACT)
    assert r.evaluation == Evaluation.EXACT and r.bound_kind == BoundKind.EXACT
    assert r.value == pytest.approx(best.value, rel=1e-12)
    assert r.value == pytest.approx(oracle(tiny(3, 3, 5, {"model": "bernoulli", "success": 0.5}), objective), rel=1e-9)
    assert r.status == "optimal" and r.gap == pytest.approx(0, abs=1e-9)
    # asked once per observed state it reaches: each observation is new
    keys = {(o["slot"], tuple(o["position"]), tuple(o["aoi"]), tuple(o["distance"])) for o in asked}
    assert len(keys) == len(asked) == r.solver["decisions"] == len(r.policy.table)


def test_the_default_bound_is_the_lossless_optimum_and_a_worse_policy_is_not_optimal():
    inst = _lossy(seed=2)
    r = voiopt.evaluate_function(inst, "mean-min-voi", lambda obs: (None, "stay"))
    lossless = voiopt.solve(voiopt.core.links.without_links(inst), "dp", "mean-min-voi")
    assert r.bound_kind == BoundKind.LOSSLESS and r.bound == pytest.approx(lossless.bound)
    assert r.status == "feasible" and r.value < r.bound
    idle = voiopt.Plan.from_indices(inst, [r.policy.steps.lat.start] * inst.horizon, [-1] * inst.horizon)
    assert r.value == pytest.approx(voiopt.evaluate(inst, idle)["mean-min-voi"], rel=1e-12)  # nothing to lose


def test_monte_carlo_of_a_function_contains_its_exact_value_and_uses_the_shared_scenarios():
    inst = _lossy(seed=4, n=2, T=5, p=0.6)
    replan = voiopt.solve(inst, "replan", "mean-min-voi")
    r = voiopt.evaluate_function(inst, "mean-min-voi", replan.policy.act, max_states=0, samples=400, seed=1)
    assert r.evaluation == Evaluation.MONTE_CARLO and r.samples == 400 and r.solver["scenario_seed"] == 1
    assert r.value_ci[0] <= replan.value <= r.value_ci[1] and r.value_ci[0] < r.value_ci[1]
    # paired: the same seed draws the same U(t, i), so the same policy gives the very same estimate
    same = monte_carlo_value(replan.policy, sample_scenarios(inst, 400, seed=1))
    assert r.value == same.mean and tuple(r.value_ci) == same.ci


@pytest.mark.parametrize("action, words", [
    ((7, "stay"), "action (sensor 7, move 'stay') is illegal at slot 0"),
    ((None, "fly"), "its move must be one of stay, N, S, E, W, got 'fly' at slot 0"),
    ("stay", "must return (sensor or None, move), got 'stay' at slot 0"),
    ((True, "stay"), "its sensor must be an integer or None, got True at slot 0"),
])
def test_a_malformed_or_illegal_action_is_refused_naming_slot_and_action(action, words):
    inst = _lossy(seed=1)
    with pytest.raises(OptionError, match="^act: " + words.replace("(", r"\(").replace(")", r"\)")):
        voiopt.evaluate_function(inst, "mean-min-voi", lambda obs: action)


def test_a_move_is_illegal_in_the_last_slot():
    inst = _lossy(seed=1)
    policy = voiopt.policy_from_function(inst, "mean-min-voi",
                                         lambda obs: (None, "stay" if obs["slot"] < inst.horizon - 1 else "N"))
    with pytest.raises(OptionError, match=rf"move 'N'\) is illegal at slot {inst.horizon - 1}.*legal: \(None, stay\)"):
        exact_value(policy)


def test_a_saved_function_policy_keeps_its_distances_and_its_value(tmp_path):
    """Under mean-max-aoi the function may still read distances: the saved table keeps them."""
    inst = _lossy(seed=5, n=2, T=4, p=0.5)

    def act(obs):  # on even slots, the first sensor whose last upload was from afar: reads the distances
        legal = [i for i in range(inst.n_sensors) if obs["distance"][i] > 0.5]
        return (legal[0] if legal and obs["slot"] % 2 == 0 else None, "stay")

    policy = voiopt.policy_from_function(inst, "mean-max-aoi", lambda obs: _in_range(policy, obs, act(obs)))
    value = exact_value(policy)
    policy.save(tmp_path / "p.json")
    loaded = Policy.load(tmp_path / "p.json")
    assert loaded.table == policy.table and loaded.uses_distance
    assert exact_value(loaded) == value


def _in_range(policy, obs, action):
    """``action`` if its sensor is in range of the observed position, else no upload."""
    t, state = policy.observed(obs)
    sensor, move = action
    return (sensor if sensor is not None and policy.steps.lat.in_range[sensor, state[0]] else None), move


def test_fleets_and_other_objectives_are_refused():
    inst = _lossy()
    with pytest.raises(OptionError, match="objective: function takes mean-min-voi or mean-max-aoi"):
        voiopt.evaluate_function(inst, "min-voi", lambda obs: (None, "stay"))
    with pytest.raises(OptionError, match="act: must be a function"):
        voiopt.policy_from_function(inst, "mean-min-voi", 3)
    with pytest.raises(OptionError, match="bound_kind: give a bound and its kind together"):
        voiopt.evaluate_function(inst, "mean-min-voi", lambda obs: (None, "stay"), bound=1.0)


def test_the_normalised_env_reward_on_a_lossy_instance_sums_to_the_realised_plans_value():
    """The reward MaskablePPO trains on (voiopt.env, reward_mode="normalised"): under lossy links
    it is divided by the optimum without links, and sums to the realised run's mean-min-voi."""
    import numpy as np

    import voiopt.env as voienv

    inst = from_dict(voiopt.load("instances/case-study.json").to_dict() | {"horizon": 6, "links": {
        "model": "bernoulli", "success": 0.5}})
    env = voienv.VoIEnv(inst, reward_mode="normalised")
    lossless = voiopt.solve(voiopt.core.links.without_links(inst), "dp", "mean-min-voi")
    assert env.optimum() == pytest.approx(lossless.value, rel=1e-12)
    rng = np.random.default_rng(3)
    failures = 0
    for episode in range(4):
        env.reset(seed=episode)
        total, done, positions, realised = 0.0, False, [], []
        while not done:
            p = env.state[0]
            _, r, done, _, info = env.step(int(rng.choice(np.flatnonzero(env.action_masks()))))
            positions.append(p)
            realised.append(env.plan().schedule[-1] if info.get("upload_success") else None)
            failures += info.get("upload_success") is False
            total += r
        plan = voiopt.Plan(positions=env.plan().positions, schedule=realised)
        assert voiopt.evaluate(inst, plan)["mean-min-voi"] == pytest.approx(total * env.optimum() / inst.horizon,
                                                                           rel=1e-9)
    assert failures > 0


def test_a_time_limit_stops_the_monte_carlo_with_the_scenarios_done():
    inst = _lossy(seed=4, n=2, T=5, p=0.6)
    r = voiopt.evaluate_function(inst, "mean-min-voi", lambda obs: (None, "stay"), max_states=0, samples=100_000,
                                 time_limit=0.5)
    assert r.status == "time_limit" and r.evaluation == Evaluation.MONTE_CARLO
    assert 2 <= r.samples < 100_000 and "time limit" in r.solver["stopped"]


def test_the_other_averaged_objective_is_given_unless_the_stop_rule_says_stop():
    """A policy's exact result holds both averaged objectives; the second enumeration honours
    the run's stop rule, and once it says stop that metric is left out, with a note."""
    from voiopt.runtime.stop import Stop
    from voiopt.solvers.policy.report import policy_result

    inst = _lossy(seed=2)
    best = voiopt.solve(inst, "policy-dp", "mean-min-voi")
    assert best.metrics["mean-max-aoi"] == pytest.approx(exact_value(best.policy, "mean-max-aoi"), rel=1e-12)
    stop = Stop()
    stop.request()
    r = policy_result(inst, "policy-dp", "mean-min-voi", best.policy, {"value": best.value, "evaluation": "exact"},
                      status="optimal", bound=best.bound, bound_kind=BoundKind.EXACT, runtime_s=0.0, stop=stop)
    assert "mean-max-aoi" not in r.metrics and "mean-max-aoi not computed" in r.solver["metrics_note"]
    assert r.value == best.value
