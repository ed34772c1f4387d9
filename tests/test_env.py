"""The Gymnasium environment as RL users expect it: check_env on sampled and loaded instances,
action_masks(), a Dict observation, infeasible actions raised or penalised (never altered
silently), plan() scored by the simulator, and the rewards of MODEL.md section 7."""

from __future__ import annotations

import random

import gymnasium
import numpy as np
import pytest
from conftest import ROOT
from gymnasium.utils.env_checker import check_env

import voiopt
import voiopt.env as voienv
from voiopt.core.simulate import simulate
from voiopt.errors import OptionError
from voiopt.grid import lattice

DOCK = ROOT / "instances" / "dock.json"


@pytest.fixture(scope="module")
def small():
    return voiopt.generate(3, 6, width=3, height=2, seed=21, rho=(0.3, 0.9))


@pytest.mark.parametrize("mode", ["ansi", "rgb_array"])
@pytest.mark.parametrize("source", ["sampled", "case-study", "dock"])
def test_check_env_passes(source, mode):
    """check_env steps random actions, so infeasible ones are penalised here, not raised."""
    kwargs = {} if source == "sampled" else {"instance": voiopt.load(ROOT / "instances" / f"{source}.json")}
    env = gymnasium.make(voienv.ENV_ID, render_mode=mode, infeasible="penalise", observe_sensors=True, **kwargs)
    check_env(env.unwrapped)


def test_make_without_arguments_samples_paper_networks():
    env = gymnasium.make(voienv.ENV_ID).unwrapped
    env.reset(seed=1)
    first = env.instance
    env.reset(seed=2)
    assert env.instance != first and env.instance.n_sensors == 4 and env.instance.horizon == 30
    env.reset(seed=1)
    assert env.instance == first  # the seed decides the network


def test_loading_an_instance_of_another_size_is_refused():
    env = gymnasium.make(voienv.ENV_ID).unwrapped
    with pytest.raises(OptionError, match="this env's spaces are for N=4"):
        env.reset(options={"instance": str(ROOT / "instances" / "case-study.json")})
    same = voiopt.generate(4, 30, seed=99)
    _, info = env.reset(options={"instance": same})
    assert info["instance"] == same.name


def test_observation_layout(small):
    env = voienv.VoIEnv(small, observe_sensors=True)
    obs, _ = env.reset()
    assert set(obs) == {"position", "aoi", "q", "slot", "sensors", "rho"}
    assert obs["slot"][0] == 0 and env.observation_space.contains(obs)
    aoi0 = np.array([s.initial_aoi for s in small.sensors])
    np.testing.assert_allclose(obs["aoi"], aoi0 / (aoi0.max() + small.horizon), rtol=1e-6)
    np.testing.assert_allclose(obs["position"], np.array(small.start) / [small.width, small.height], rtol=1e-6)


def test_infeasible_actions_raise_or_are_penalised(case_study):
    env = voienv.VoIEnv(case_study, reward_units="bit/s/Hz")  # V/B < 1: the penalty shows
    env.reset()
    mask = env.action_masks()
    bad = int(np.flatnonzero(~mask)[0])
    with pytest.raises(OptionError, match="is infeasible in slot 0"):
        env.step(bad)
    env = voienv.VoIEnv(case_study, reward_units="bit/s/Hz", infeasible="penalise", render_mode="ansi")
    env.reset()
    obs, r, _, _, info = env.step(bad)
    assert info["infeasible"] and r < -199  # idle and infeasible: two penalties
    text = env.render()
    assert text.count("R") == 1 and "slot 1/10" in text and "sensor 2 at" in text


@pytest.mark.parametrize("path", ["case-study", "dock"])
@pytest.mark.parametrize("mode", ["paper", "normalised"])
@pytest.mark.parametrize("play, penalty", [("masked", 100.0), ("unmasked", 100.0), ("unmasked", 7.5)])
def test_random_rollout_plan_matches_the_summed_reward(path, mode, play, penalty):
    """The documented account (docs/qlearning.md): also for unmasked play with
    infeasible="penalise" and another penalty (until 2026-12-03 the docs left the penalised
    steps out and wrote 100 for the penalty, a probe found)."""
    inst = voiopt.load(ROOT / "instances" / f"{path}.json")
    env = voienv.VoIEnv(inst, reward_mode=mode, infeasible="penalise", penalty=penalty)
    rng = random.Random(7)
    penalised = 0
    for episode in range(3):
        _, info = env.reset(seed=episode)
        total, done = 0.0, False
        while not done:
            choices = np.flatnonzero(env.action_masks()) if play == "masked" else np.arange(env.action_space.n)
            _, r, done, _, info = env.step(rng.choice(choices.tolist()))
            total += r
        penalised += info["infeasible_steps"]
        value = voiopt.evaluate(inst, env.plan())["mean-min-voi"]  # a whole, legal plan
        T = inst.horizon
        if mode == "paper":  # (sum r + penalty * (idle slots + infeasible steps)) / T
            expect = (total + penalty * (info["idle_slots"] + info["infeasible_steps"])) / T
        else:  # (sum r + penalty * infeasible steps) * optimum / T
            expect = (total + penalty * info["infeasible_steps"]) * env.optimum() / T
        assert value == pytest.approx(expect, rel=1e-9)
    assert (penalised > 0) == (play == "unmasked")


@pytest.mark.parametrize("reward", ["voi", "aoi"])
def test_milp_plan_through_the_env_pays_the_simulators_rewards(small, reward):
    result = voiopt.solve(small, method="milp", objective="mean-min-voi")
    assert result.status == "optimal"
    plan, traj = result.plan, simulate(small, result.plan)
    lat = lattice.build(small)
    env = gymnasium.make(voienv.ENV_ID, instance=small, reward=reward).unwrapped
    obs, info = env.reset(seed=0)
    for t in range(small.horizon):
        p = traj.positions[t]
        move = 0 if t + 1 == small.horizon else _move(lat, p, lat.index(*plan.positions[t + 1]))
        u = plan.schedule[t]
        action = (0 if u is None else u + 1) * 5 + move
        assert info["action_mask"][action]
        obs, r, terminated, truncated, info = env.step(action)
        idle = 100.0 if u is None else 0.0
        expect = traj.voi[t + 1].min() - idle if reward == "voi" else -traj.aoi[t + 1].max() - idle
        assert r == pytest.approx(expect, rel=1e-12)
        assert not info["infeasible"] and not truncated
        assert terminated == (t + 1 == small.horizon)
    assert env.plan() == plan


def _move(lat, p, q):
    return int(np.flatnonzero(lat.neighbors[p] == q)[0])


def test_rgb_render_is_an_image(case_study):
    env = voienv.VoIEnv(case_study, render_mode="rgb_array")
    env.reset()
    img = env.render()
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    assert (img == [0x1F, 0x77, 0xB4]).all(axis=2).any()  # the robot is drawn (robot 0's colour)


@pytest.mark.parametrize("kwargs, message", [
    (dict(sample={"sensors": 6}), "sample: unknown key 'sensors' (allowed: n_sensors, "),
    (dict(sample=[4]), "sample: must be a dict"),
    (dict(sample={"robots": 2}), "sample: robots: the env samples one-robot networks, got 2"),  # reset crashed
    (dict(instance=str(ROOT / "instances" / "case-study.json"), sample={"n_sensors": 3}),
     "sample: draws the networks of an env without an instance; got instance= as well"),  # sample was ignored
    (dict(reward="aoi", reward_mode="normalised"), "with reward='aoi' use reward_mode='paper'"),
    (dict(penalty=float("nan")), "penalty: must be a finite number >= 0, got nan"),
    (dict(penalty=float("inf")), "penalty: must be a finite number >= 0, got inf"),
    (dict(penalty="100"), "penalty: must be a finite number >= 0, got '100'"),
    (dict(observe_sensors="no"), "observe_sensors: must be True or False, got 'no'"),  # taken as true before
])
def test_options_that_would_be_ignored_or_poison_the_rewards_are_refused(kwargs, message):
    with pytest.raises(OptionError) as e:
        voienv.VoIEnv(**kwargs)
    assert message in str(e.value)


def test_an_action_is_an_integer_not_anything_int_accepts(case_study):
    env = voienv.VoIEnv(case_study)
    env.reset()
    for bad in (0.7, "3", True, np.float64(5.0)):
        with pytest.raises(OptionError, match="action: must be an integer in 0..19"):
            env.step(bad)
    for good in (np.int64(0), np.array(0), np.array([0])):  # what agents pass
        env.reset()
        env.step(good)


def test_the_normalised_reward_on_an_open_certificate_is_refused_not_solved_for_ever(monkeypatch):
    import copy

    from voiopt.voilib import library as voilib

    inst = voilib.instances()["factory-n12-t100-000"]
    shipped = copy.deepcopy(voilib.certificates())  # every certificate of VoI-Lib 1.2 is optimal; 1.1 had this one open
    shipped["instances"][inst.name]["certificates"]["mean-min-voi"].update(
        status="bounded", value=38459.713929616475, bound=38459.74135562068)
    monkeypatch.setattr(voilib, "certificates", lambda: shipped)
    with pytest.raises(OptionError, match="certificate of factory-n12-t100-000 is open"):
        voienv.VoIEnv(inst, reward_mode="normalised")  # up front, not at the first step
    env = voienv.VoIEnv(inst)  # the paper's reward needs no optimum
    env.reset()
    env.step(int(np.flatnonzero(env.action_masks())[0]))


def test_no_action_is_legal_once_the_episode_has_ended(case_study):
    env = voienv.VoIEnv(case_study)
    env.reset()
    for _ in range(case_study.horizon):
        *_, info = env.step(int(np.flatnonzero(env.action_masks())[0]))
    assert not info["action_mask"].any() and not env.action_masks().any()


def test_the_api_takes_a_path_and_refuses_what_is_no_instance_in_one_line(case_study):
    """gymnasium.make(..., instance=path) raised an AttributeError where reset's options took a
    path; a number gave a TypeError; a step after the end a RuntimeError (a probe, 2026-12-03)."""
    path = str(ROOT / "instances" / "case-study.json")
    loads = []
    with pytest.MonkeyPatch.context() as mp:  # the file is read once (until 2026-12-03, twice)
        mp.setattr(voiopt.core.instance, "load", lambda p, _load=voiopt.core.instance.load: loads.append(p) or _load(p))
        env = gymnasium.make(voienv.ENV_ID, instance=path)
    assert env.unwrapped.instance == case_study and loads == [path]
    with pytest.raises(OptionError, match=r"^instance: must be an Instance or the path of an instance file, got 5$"):
        gymnasium.make(voienv.ENV_ID, instance=5)
    env.reset()
    with pytest.raises(OptionError, match=r"^options.instance: must be an Instance or the path"):
        env.reset(options={"instance": 5})
    for _ in range(case_study.horizon):
        env.step(int(env.unwrapped.action_masks().argmax()))
    with pytest.raises(OptionError, match=r"^step: the episode has ended \(slot 10 of 10\): call reset\(\)$"):
        env.step(0)


def test_a_step_before_reset_is_refused(case_study):
    """Made directly (not by gymnasium.make, whose wrapper enforces the order), the env stepped
    from its start state without a reset (a probe, 2026-12-03)."""
    env = voienv.VoIEnv(case_study)
    with pytest.raises(OptionError, match=r"^step: no episode has started: call reset\(\) first$"):
        env.step(0)
    env.reset(seed=0)
    env.step(int(env.action_masks().argmax()))
    for bad in ([1], "x"):  # read as unknown keys 1 and 'x' before
        with pytest.raises(OptionError, match=r"^options: must be a dict such as \{'instance': path\}, got "):
            env.reset(options=bad)
