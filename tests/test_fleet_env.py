"""The environments for several robots (MODEL.md section 10): the Gymnasium env's joint action
and its exact mask (checked against the oracle's legal plans), check_env, plans scored by the
simulator and the oracle, and the PettingZoo ParallelEnv (PettingZoo's own API test, the
documented resolution of conflicting agents)."""

from __future__ import annotations

import subprocess
import sys
import warnings

import gymnasium
import numpy as np
import pytest
from conftest import ROOT, fleet_instances
from gymnasium.utils.env_checker import check_env
from oracles import model_oracle as oracle
from pettingzoo.test import parallel_api_test

import voiopt
import voiopt.env as voienv
from voiopt.core.plan import FleetPlan
from voiopt.core.simulate import simulate
from voiopt.errors import OptionError
from voiopt.pz_env import VoIParallelEnv, parallel_env

CASES = fleet_instances()
MOVES = [(0, 0), (0, 1), (0, -1), (1, 0), (-1, 0)]


@pytest.mark.parametrize("mode", ["ansi", "rgb_array"])
@pytest.mark.parametrize("inst", CASES[:4], ids=lambda i: i.name)
def test_check_env_passes_for_a_fleet(inst, mode):
    env = gymnasium.make(voienv.ENV_ID, instance=inst, render_mode=mode, infeasible="penalise", observe_sensors=True)
    assert isinstance(env.unwrapped, voienv.FleetVoIEnv)
    assert env.action_space.n == ((inst.n_sensors + 1) * 5) ** 2
    check_env(env.unwrapped)


@pytest.mark.parametrize("inst", CASES, ids=lambda i: i.name)
def test_the_first_mask_is_exactly_the_first_slot_of_the_legal_plans(inst):
    """The oracle's legal plans, enumerated, give the joint actions a legal plan can begin with."""
    env = voienv.VoIEnv(inst)
    env.reset()
    want = set()
    for plan in oracle.legal_plans(inst.to_dict()):
        acts = []
        for r in plan["robots"]:
            (x0, y0), (x1, y1) = r["positions"][:2]
            u = r["schedule"][0]
            acts.append((0 if u is None else u + 1) * 5 + MOVES.index((round(x1 - x0), round(y1 - y0))))
        want.add(env.joint_action(acts))
    assert set(np.flatnonzero(env.action_masks()).tolist()) == want


@pytest.mark.parametrize("inst", CASES, ids=lambda i: i.name)
def test_random_masked_rollouts_are_legal_and_the_rewards_add_up(inst):
    env = voienv.VoIEnv(inst)
    rng = np.random.default_rng(len(inst.name))
    for episode in range(10):
        obs, info = env.reset(seed=episode)
        assert obs["position"].shape == (2, 2)
        total, done = 0.0, False
        while not done:
            obs, r, done, _, info = env.step(int(rng.choice(np.flatnonzero(info["action_mask"]))))
            assert not info["infeasible"]
            total += r
        plan = env.plan()
        assert isinstance(plan, FleetPlan)
        got = simulate(inst, plan).metrics  # the simulator checks every rule between robots
        assert oracle.simulate(inst.to_dict(), plan.to_dict())["mean-min-voi"] == pytest.approx(got["mean-min-voi"])
        # the penalty is paid once per robot and slot without an upload
        assert info["infeasible_steps"] == 0
        assert (total + 100.0 * info["idle_slots"]) / inst.horizon == pytest.approx(got["mean-min-voi"], rel=1e-9)


def test_illegal_joint_actions_raise_or_are_penalised():
    inst = CASES[0]
    env = voienv.VoIEnv(inst, reward_units="bit/s/Hz")
    env.reset()
    bad = int(np.flatnonzero(~env.action_masks())[0])
    with pytest.raises(OptionError, match="is illegal in slot 0"):
        env.step(bad)
    env = voienv.VoIEnv(inst, reward_units="bit/s/Hz", infeasible="penalise")
    env.reset()
    _, r, _, _, info = env.step(bad)
    assert info["infeasible"] and r < -100 and info["infeasible_steps"] == 1
    with pytest.raises(OptionError, match="no certified optimum"):
        voienv.VoIEnv(inst, reward_mode="normalised")
    with pytest.raises(OptionError, match="has 1 robot"):
        env.reset(options={"instance": voiopt.case_study()})


@pytest.mark.parametrize("inst", [*CASES[:6], voiopt.case_study()], ids=lambda i: i.name)
def test_pettingzoo_parallel_api_test_passes(inst):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # PettingZoo reports API slips as warnings
        parallel_api_test(parallel_env(instance=inst, render_mode="ansi"), num_cycles=20)


@pytest.mark.parametrize("inst", CASES, ids=lambda i: i.name)
def test_agents_sampling_their_own_masks_always_make_a_legal_plan(inst):
    env = parallel_env(instance=inst)
    rng = np.random.default_rng(3)
    for episode in range(5):
        obs, _ = env.reset(seed=episode)
        assert env.agents == ["robot_0", "robot_1"]
        while env.agents:
            assert all(env.observation_space(a).contains(obs[a]) for a in env.agents)
            actions = {a: int(rng.choice(np.flatnonzero(obs[a]["action_mask"]))) for a in env.agents}
            obs, rewards, *_, infos = env.step(actions)
            assert not infos["robot_0"]["replaced"]  # robot 0 sampled from its mask: it always stands
            for a in actions:
                assert (infos[a]["executed"] == actions[a]) != infos[a]["replaced"]
        simulate(inst, env.plan())


def test_a_conflict_replaces_the_higher_indexed_agent():
    """Two robots side by side, both told to move onto the same free point: robot 0 moves,
    robot 1 keeps its place (its move is replaced by the first action that extends robot 0's)."""
    d = voiopt.generate(1, 3, width=1.0, height=1.0, seed=5, power_w=1.0).to_dict()
    del d["start"]
    d["robots"] = [{"start": [0, 0]}, {"start": [1, 1]}]
    env = parallel_env(instance=voiopt.core.instance.from_dict(d))
    env.reset()
    north, west = 1, 4  # robot 0 from (0, 0) north to (0, 1); robot 1 from (1, 1) west to (0, 1)
    _, rewards, _, _, infos = env.step({"robot_0": north, "robot_1": west})
    assert not infos["robot_0"]["replaced"] and infos["robot_1"]["replaced"]
    assert rewards["robot_1"] == rewards["robot_0"] - 100.0
    assert env.env.state[0][0] == 1 and infos["robot_1"]["executed"] % 5 != west  # (0, 1) is point 1


def test_an_agents_action_is_an_integer_as_in_the_gym_env():
    """pz_env read int(0.7) as action 0 and crashed on a one-element array; the Gym env refuses
    the first and takes the second, and so does each agent now."""
    env = VoIParallelEnv(voiopt.load(ROOT / "instances" / "fleet.json"))
    env.reset(seed=0)
    first = env.possible_agents[0]
    for bad in (0.7, np.float64(0.2), "0"):
        with pytest.raises(OptionError, match=rf"actions\['{first}'\]: must be an integer"):
            env.step(dict.fromkeys(env.agents, bad))
    _, _, _, _, infos = env.step(dict.fromkeys(env.agents, np.array([0])))
    assert not any(i["replaced"] for i in infos.values())


def test_actions_that_are_no_agents_choice_and_steps_outside_an_episode_are_refused():
    """A missing, out-of-range or None action was executed as a replacement (only conflicts are
    replaced), a list of actions raised AttributeError and a step after the last slot
    ValueError: min() arg is an empty sequence (a probe, 2026-12-03)."""
    env = VoIParallelEnv(voiopt.load(ROOT / "instances" / "fleet.json"))
    with pytest.raises(OptionError, match=r"^step: no episode is running .*call reset\(\)$"):
        env.step({"robot_0": 0, "robot_1": 0})
    env.reset(seed=0)
    n = env.action_space("robot_0").n
    for actions, message in [
        ({"robot_0": 0}, r"^actions: no action for 'robot_1' \(every agent acts in every slot\)$"),
        ({}, r"^actions: no action for 'robot_0'"),
        ({"robot_0": 0, "robot_1": n}, rf"^actions\['robot_1'\]: must be in 0..{n - 1}, got {n}$"),
        ({"robot_0": -1, "robot_1": 0}, rf"^actions\['robot_0'\]: must be in 0..{n - 1}, got -1$"),
        ({"robot_0": None, "robot_1": 0}, r"^actions\['robot_0'\]: must be an integer"),
        ({"robot_0": 0, "robot_1": 0, "robot_9": 0}, r"^actions: unknown agent 'robot_9' \(the agents: robot_0, robot_1\)$"),
        ([0, 0], r"^actions: must be a dict of agent -> action, got list$"),
    ]:
        with pytest.raises(OptionError, match=message):
            env.step(actions)
    assert env.env.t == 0  # nothing was executed
    while env.agents:
        env.step(dict.fromkeys(env.agents, 0))
    with pytest.raises(OptionError, match=r"^step: no episode is running"):
        env.step({"robot_0": 0, "robot_1": 0})
    with pytest.raises(OptionError, match=r"^options: must be a dict"):
        env.reset(options=[1])


def test_core_voiopt_does_not_import_pettingzoo():
    code = "import sys, voiopt, voiopt.env; assert 'pettingzoo' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_both_envs_check_an_action_with_one_helper(monkeypatch):
    """The PettingZoo env's action check was a twin of the Gymnasium env's (issue 47): both now
    call voiopt.env.action_in, and say the same of the same bad action."""
    import voiopt.pz_env as pz

    env = VoIParallelEnv(voiopt.load(ROOT / "instances" / "fleet.json"))
    env.reset(seed=0)
    n = env.action_space("robot_0").n
    gym_env = voienv.VoIEnv(voiopt.load(ROOT / "instances" / "case-study.json"))
    gym_env.reset(seed=0)
    m = gym_env.action_space.n
    with pytest.raises(OptionError, match=rf"^actions\['robot_0'\]: must be in 0..{n - 1}, got {n}$"):
        env.step({"robot_0": np.array([n]), "robot_1": 0})
    with pytest.raises(OptionError, match=rf"^action: must be in 0..{m - 1}, got {m}$"):  # the array's value, as above
        gym_env.step(np.array([m]))
    asked = []
    monkeypatch.setattr(pz, "action_in", lambda a, k, what: asked.append(what) or voienv.action_in(a, k, what))
    env.step({"robot_0": 0, "robot_1": 0})
    assert asked == ["actions['robot_0']", "actions['robot_1']"]
