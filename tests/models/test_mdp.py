"""The MDP encoding: packing is exact, actions are the feasible set, step/reward = simulator."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import tiny_instances

import voiopt
from voiopt.core.plan import Plan
from voiopt.core.simulate import simulate
from voiopt.errors import OptionError
from voiopt.grid import lattice
from voiopt.mdp import robot as mdp


def _random_walk(model, rng, steps):
    state, states, actions = model.initial_state(), [], []
    for _ in range(steps):
        k = int(rng.integers(model.n_actions[state[0]]))
        states.append(state)
        actions.append(k)
        state, _ = model.step(state, k)
    return states, actions, state


@pytest.mark.parametrize("n_sensors,slot", [(3, False), (20, True)])
def test_encode_decode_round_trip_including_multi_word_keys(n_sensors, slot):
    inst = voiopt.generate(n_sensors, 60, seed=n_sensors, initial_aoi=(1, 50))
    model = mdp.build(inst, slot_in_state=slot)
    states, _, last = _random_walk(model, np.random.default_rng(0), inst.horizon)
    keys = set()
    for s in [*states, last]:
        key = model.encode(s)
        assert model.decode(key) == s
        keys.add(tuple(key.tolist()))
    assert len(keys) == len({*states, last})  # distinct states, distinct keys
    assert (model.n_words > 1) == (n_sensors == 20)


def test_actions_are_exactly_the_feasible_set(case_study):
    model = mdp.build(case_study)
    lat = lattice.build(case_study)
    for p in range(lat.n_points):
        acts = model.actions(p)
        uploads = {-1, *np.flatnonzero(lat.in_range[:, p]).tolist()}
        moves = {m for m in range(5) if lat.neighbors[p, m] >= 0}
        assert set(acts) == {(u, m) for u in uploads for m in moves}
        assert len(acts) == len(set(acts)) == model.n_actions[p]
        for k, (u, m) in enumerate(acts):
            assert model.action_next[p, k] == lat.neighbors[p, m]
            assert model.action_number(p, u, m) == k


@pytest.mark.parametrize("inst", tiny_instances(6, seed=7) + [voiopt.generate(4, 30, seed=3)], ids=lambda i: i.name)
def test_step_and_reward_follow_the_simulator(inst):
    rng = np.random.default_rng(1)
    for reward, units in (("voi", "bit/s"), ("voi", "bit/s/Hz"), ("aoi", "bit/s")):
        model = mdp.build(inst, reward, reward_units=units)
        states, actions, _ = _random_walk(model, rng, inst.horizon)
        idx = [s[0] for s in states]
        sched = [int(model.action_upload[s[0], k]) for s, k in zip(states, actions, strict=True)]
        traj = simulate(inst, Plan.from_indices(inst, idx, sched))
        state = model.initial_state()
        for t, k in enumerate(actions):
            state, r = model.step(state, k)
            idle = 100.0 if sched[t] < 0 else 0.0
            np.testing.assert_array_equal(state[1], traj.aoi[t + 1])
            if reward == "voi":
                scale = inst.channel.bandwidth_hz if units == "bit/s/Hz" else 1.0
                expect = traj.voi[t + 1].min() / scale - idle
                assert r == pytest.approx(expect, rel=1e-12, abs=1e-15)
            else:
                assert r == -traj.aoi[t + 1].max() - idle
            for i, q in enumerate(state[2]):
                d = inst.initial_distance(i) if q == 0 else lattice.build(inst).distance[i, q - 1]
                assert d == traj.distance[t + 1, i]


def test_bad_reward_is_an_option_error(case_study):
    with pytest.raises(OptionError, match="reward"):
        mdp.build(case_study, "mse")
    with pytest.raises(OptionError, match="reward_units"):
        mdp.build(case_study, reward_units="bit/Hz")


def test_default_reward_is_the_paper_as_written_in_bit_per_second(case_study):
    model = mdp.build(case_study)
    hz = mdp.build(case_study, reward_units="bit/s/Hz")
    assert model.reward_units == "bit/s" and model.penalty == 100.0
    np.testing.assert_allclose(model.voi_reward, hz.voi_reward * case_study.channel.bandwidth_hz, rtol=1e-15)
