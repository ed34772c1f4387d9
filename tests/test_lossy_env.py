"""The envs under lossy links (MODEL.md section 11): upload outcomes drawn with the env's seed,
reported in info["upload_success"], a failed upload acting as no upload (without f_penalty),
and, on an instance whose every probability is 1, exactly the lossless env."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT, fleet_instances

import voiopt
import voiopt.env as voienv
from voiopt.core.instance import from_dict
from voiopt.core.links import success_probability
from voiopt.core.plan import FleetPlan, Plan
from voiopt.core.simulate import simulate
from voiopt.pz_env import parallel_env

PENALTY = 100.0


def with_links(inst, links):
    return from_dict(inst.to_dict() | {"links": links})


def episode(env, seed, rng, upload=False):
    """A random masked episode, [(obs, reward, info, action)], uploading whenever it can with ``upload``."""
    obs, info = env.reset(seed=seed)
    out = [(obs, None, info, None)]
    done = False
    while not done:
        legal = np.flatnonzero(env.action_masks())
        ups = legal[legal >= 5]
        a = int(rng.choice(ups if upload and len(ups) else legal))
        obs, r, done, _, info = env.step(a)
        out.append((obs, r, info, a))
    return out


@pytest.mark.parametrize("links", [{"model": "bernoulli", "success": 1}, {"model": "rayleigh", "snr_threshold_db": -1e6}])
def test_success_one_is_the_lossless_env_step_for_step(links):
    inst = voiopt.load(ROOT / "instances" / "case-study.json")
    a, b = voienv.VoIEnv(inst), voienv.VoIEnv(with_links(inst, links))
    for seed in range(3):
        ea, eb = episode(a, seed, np.random.default_rng(seed)), episode(b, seed, np.random.default_rng(seed))
        for (oa, ra, ia, _), (ob, rb, ib, _) in zip(ea, eb, strict=True):
            assert ra == rb and set(ia) == set(ib) and "upload_success" not in ib
            assert all(np.array_equal(oa[k], ob[k]) for k in oa)
        assert a.np_random.bit_generator.state == b.np_random.bit_generator.state
        assert a.plan() == b.plan()


def realised(env, steps) -> Plan:
    """The lossless plan the episode realised: failed uploads as null."""
    plan = env.plan()
    sched = [None if (info.get("upload_success") is False) else u
             for u, (_, _, info, _) in zip(plan.schedule, steps[1:], strict=True)]
    return Plan(plan.positions, tuple(sched))


@pytest.mark.parametrize("reward", ["voi", "aoi"])
def test_a_failed_upload_acts_as_no_upload_without_the_penalty(reward):
    inst = with_links(voiopt.load(ROOT / "instances" / "case-study.json"), {"model": "bernoulli", "success": 0.5})
    env = voienv.VoIEnv(inst, reward=reward)
    failures = successes = 0
    for seed in range(12):
        steps = episode(env, seed, np.random.default_rng(10 + seed), upload=True)
        traj = simulate(inst, realised(env, steps))
        for t, (_, r, info, _) in enumerate(steps[1:]):
            u = env.plan().schedule[t]
            got = info.get("upload_success")
            assert (got is None) == (u is None)
            failures += got is False
            successes += got is True
            idle = PENALTY if u is None else 0.0
            expect = traj.voi[t + 1].min() - idle if reward == "voi" else -traj.aoi[t + 1].max() - idle
            assert r == pytest.approx(expect, rel=1e-12)
    assert failures > 0 and successes > 0


def test_outcomes_follow_the_seed_and_the_success_probability():
    inst = with_links(voiopt.load(ROOT / "instances" / "case-study.json"), {"model": "rayleigh", "snr_threshold_db": 27.0})
    env = voienv.VoIEnv(inst)
    lat = env.lattice
    outcomes, expected = [], []
    for seed in range(80):
        steps = episode(env, seed, np.random.default_rng(seed), upload=True)
        again = episode(env, seed, np.random.default_rng(seed), upload=True)
        assert [s[2].get("upload_success") for s in steps] == [s[2].get("upload_success") for s in again]
        plan = env.plan()
        for t, (_, _, info, _) in enumerate(steps[1:]):
            u = plan.schedule[t]
            if u is not None:
                outcomes.append(info["upload_success"])
                expected.append(success_probability(inst, u, float(lat.distance[u, lat.index(*plan.positions[t])])))
    p = np.array(expected)
    assert len(outcomes) > 100 and 0.1 < p.mean() < 0.9
    assert abs(sum(outcomes) - p.sum()) < 4 * np.sqrt((p * (1 - p)).sum())


def test_fleet_env_and_pettingzoo_report_each_robots_outcome():
    inst = with_links(fleet_instances(3, seed=21)[0], {"model": "bernoulli", "success": 0.5})
    env = voienv.VoIEnv(inst)
    rng = np.random.default_rng(1)
    seen = set()
    for seed in range(5):
        steps = episode(env, seed, rng)
        plan = env.plan()
        sched = [list(r.schedule) for r in plan.robots]
        for t, (_, _, info, _) in enumerate(steps[1:]):
            got = info["upload_success"]
            assert len(got) == inst.n_robots
            for k, ok in enumerate(got):
                assert (ok is None) == (sched[k][t] is None)
                seen.add(ok)
                if ok is False:
                    sched[k][t] = None
        real = FleetPlan(tuple(Plan(r.positions, tuple(s)) for r, s in zip(plan.robots, sched, strict=True)))
        traj = simulate(inst, real)
        idle = [sum(s[t] is None and plan.robots[k].schedule[t] is None for k, s in enumerate(sched)) for t in range(inst.horizon)]
        rewards = [s[1] for s in steps[1:]]
        assert rewards == pytest.approx([traj.voi[t + 1].min() - PENALTY * idle[t] for t in range(inst.horizon)], rel=1e-12)
    assert {True, False} <= seen
    pz = parallel_env(instance=inst)
    obs, _ = pz.reset(seed=0)
    while pz.agents:
        actions = {a: int(rng.choice(np.flatnonzero(obs[a]["action_mask"]))) for a in pz.agents}
        obs, _, _, _, infos = pz.step(actions)
        assert all("upload_success" in infos[a] for a in infos)
