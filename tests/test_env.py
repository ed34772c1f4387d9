"""The Gymnasium environment: passes check_env, masks actions, and driven with the MILP's plan
it pays exactly the rewards of MODEL.md section 7 computed from the simulator."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from conftest import ROOT
from gymnasium.utils.env_checker import check_env

import voiopt
import voiopt.env as voienv
from voiopt import lattice
from voiopt.simulate import simulate


@pytest.fixture(scope="module")
def small():
    return voiopt.generate(3, 6, width=3, height=2, seed=21, rho=(0.3, 0.9))


@pytest.mark.parametrize("mode", ["ansi", "rgb_array"])
def test_check_env_passes(case_study, mode):
    check_env(gymnasium.make(voienv.ENV_ID, instance=case_study, render_mode=mode).unwrapped)


@pytest.mark.parametrize("mode", ["ansi", "rgb_array"])
def test_check_env_passes_with_the_field_rules(mode):
    dock = voiopt.load(ROOT / "instances" / "dock.json")  # blocked points, an end and a budget
    check_env(gymnasium.make(voienv.ENV_ID, instance=dock, render_mode=mode).unwrapped)


@pytest.mark.parametrize("reward", ["voi", "aoi"])
def test_milp_plan_through_the_env_pays_the_simulators_rewards(small, reward):
    result = voiopt.solve(small, method="milp", objective="mean-min-voi")
    assert result.status == "optimal"
    plan, traj = result.plan, simulate(small, result.plan)
    lat = lattice.build(small)
    env = gymnasium.make(voienv.ENV_ID, instance=small, reward=reward)
    obs, info = env.reset(seed=0)
    for t in range(small.horizon):
        p = traj.positions[t]
        assert tuple(lat.coords[p]) == tuple(obs[:2])
        move = 0 if t + 1 == small.horizon else _move(lat, p, lat.index(*plan.positions[t + 1]))
        u = plan.schedule[t]
        action = (0 if u is None else u + 1) * 5 + move
        assert info["action_mask"][action]
        obs, r, terminated, truncated, info = env.step(action)
        idle = 100.0 if u is None else 0.0
        expect = traj.voi[t + 1].min() - idle if reward == "voi" else -traj.aoi[t + 1].max() - idle
        assert r == pytest.approx(expect, rel=1e-12)
        assert info["feasible"] and not truncated
        assert terminated == (t + 1 == small.horizon)
        np.testing.assert_array_equal(obs[2:2 + small.n_sensors], traj.aoi[t + 1])


def _move(lat, p, q):
    return int(np.flatnonzero(lat.neighbors[p] == q)[0])


def test_mask_and_infeasible_actions(case_study):
    env = voienv.VoIEnv(case_study, render_mode="ansi", reward_units="bit/s/Hz")  # V/B < 1: the penalty shows
    _, info = env.reset()
    mask = info["action_mask"]
    assert mask.shape == (20,) and mask.sum() == env.model.n_actions[env.model.start]
    bad = int(np.flatnonzero(~mask)[0])
    obs, r, _, _, info = env.step(bad)
    assert not info["feasible"] and r < -99  # executed without an upload: the idle penalty
    np.testing.assert_array_equal(obs[2:5], np.array([2, 4, 4]) + 1)
    text = env.render()
    assert text.count("R") == 1 and "slot 1/10" in text


def test_rgb_render_is_an_image(case_study):
    env = voienv.VoIEnv(case_study, render_mode="rgb_array")
    env.reset()
    img = env.render()
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    assert (img == [220, 40, 40]).all(axis=2).any()  # the entity is drawn
