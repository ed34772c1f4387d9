"""The paper's Q-learning schemes as solvers: options, the training loop with progress and
the stop rule, and the result of the greedy plan (MODEL.md section 7)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.links import is_lossy
from voiopt.core.plan import Plan
from voiopt.core.policy_value import DEFAULT_SAMPLES
from voiopt.core.result import Result
from voiopt.core.simulate import simulate_indices
from voiopt.errors import (
    MemoryLimitError,
    OptionError,
    check_episodes,
    check_seed,
    check_stream_seeds,
)
from voiopt.grid import joint
from voiopt.grid import lattice as lattice_mod
from voiopt.mdp import fleet as fleet_mdp
from voiopt.mdp import robot as mdp_mod
from voiopt.objectives import AOI_DEFAULT, DEFAULT, Worth
from voiopt.runtime.progress import progress_bar, text_column
from voiopt.runtime.status import Status
from voiopt.runtime.stop import MEMORY_LIMIT, Stopped, watch
from voiopt.solvers import base, options
from voiopt.solvers.qlearning import fleet as fleet_kernels
from voiopt.solvers.qlearning.kernels import rollout, train
from voiopt.solvers.qlearning.rng import seed_state
from voiopt.solvers.qlearning.table import QTable

BETA, GAMMA, EPISODES = 0.75, 0.9, 1_000_000
# steps (episodes x T) of the kernel's first call, and the fewest and most of any call; the stop
# rule is checked between calls, which aim at 0.25 s each (2000, 100 and 200,000 episodes at T = 30)
FIRST_STEPS, MIN_STEPS, MAX_STEPS = 60_000, 3_000, 6_000_000
ACTIONS_PER_STEP = 64  # a step scans at most this many actions (one robot: 5 moves x (1 + sensors in range))


def warm_up(fleet: bool = False) -> float:
    """Compile (or load from numba's cache) the one-robot kernels, or with ``fleet`` the fleet
    kernels, once per process, on a tiny MDP, so that a solve's runtime_s measures Algorithm 1
    alone; returns the seconds this took (0 when already done). Only the kernels a run needs
    are loaded: each costs start-up. The kernels' argument types do not depend on the instance."""

    def load():
        from voiopt.core.instance import from_dict
        from voiopt.networks.generate import generate

        tiny = generate(1, 2, width=1.0, height=1.0, seed=0, name="warm-up")
        if fleet:
            tiny = tiny.to_dict()
            del tiny["start"]
            model = fleet_mdp.build(from_dict({**tiny, "robots": [{"start": [0, 0]}, {"start": [1, 1], "end": [1, 0]}]}))
            table = QTable(model, 0.0, 64 * 2**20, slots=16)
            fleet_kernels.train(model, table, 1, np.array([1.0]), 1.0, BETA, GAMMA, np.array([1], dtype=np.uint64))
            fleet_kernels.rollout(model, table)
        else:
            model = mdp_mod.build(tiny)
            table = QTable(model, 0.0, 64 * 2**20)
            train(model, table, 1, np.array([1.0]), 1.0, BETA, GAMMA, np.array([1], dtype=np.uint64))
            rollout(model, table)

    return base.warm_up_once("qlearning-fleet" if fleet else "qlearning", load)


def _check_options(episodes, seed, beta, gamma, q_init, penalty):
    def bad(name, value, rule):
        raise OptionError(f"{name}: {rule}, got {value!r}")

    check_episodes(episodes)
    for name, v in (("beta", beta), ("gamma", gamma)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v <= 1:
            bad(name, v, "must be in (0, 1]")
    if isinstance(q_init, bool) or not isinstance(q_init, (int, float)) or not math.isfinite(q_init):
        bad("q_init", q_init, "must be a finite number")
    mdp_mod.check_penalty(penalty)


def mdp_bytes(instance: Instance) -> float:
    """An upper bound on the bytes of the MDP's arrays (models/mdp.py) and the first Q-table."""
    N, n, T = instance.n_sensors, lattice_mod.n_points(instance), instance.horizon
    max_age = max(s.initial_aoi for s in instance.sensors) + T
    return base.lattice_bytes(instance) + 8.0 * N * (max_age + 1) * (n + 1) + 3 * 8.0 * n * 5 * (N + 1) + 2**15 * 8 * (2 * N + 4)


def _require_fleet_memory(instance: Instance, memory_limit: float) -> None:
    """Refuse, in one line and before allocating, a fleet whose joint Q-table cannot be held:
    a joint row longer than a table row may be (16-bit greedy action), or the joint mask, the
    reward table and a first table with one episode's rows over ``memory_limit``."""
    size = fleet_mdp.sizes(instance, fleet_kernels.FLEET_SLOTS)
    K, J, n = instance.n_robots, int(size["joint_actions"]), lattice_mod.n_points(instance)
    what = (f"{K} robots, up to {size['per_robot_actions']}^{K} = {J} joint actions a state, "
            f"{n}^{K} = {int(size['joint_points'])} joint points, T = {instance.horizon}")
    if J > fleet_mdp.MAX_JOINT_ACTIONS:
        raise MemoryLimitError(f"robots: the joint Q-table cannot hold {what}: a state may have at most "
                               f"{fleet_mdp.MAX_JOINT_ACTIONS} joint actions (use fewer robots, or fewer sensors in range)")
    base.require_memory(size["bytes"], memory_limit, f"the joint Q-table and masks ({what})")


METHOD_OF_REWARD = {"voi": "qlearning", "aoi": "aoi-qlearning"}


def _run(instance: Instance, objective: str, reward: str, *, progress: bool,
         episodes: int, seed: int, beta: float, gamma: float, q_init: float, penalty: float,
         time_limit: float | None, memory_limit: float, slot_in_state: bool, reward_units: str,
         samples: int = DEFAULT_SAMPLES, ir_samples: int = 0) -> Result:
    objective = objectives.get(objective)
    _check_options(episodes, seed, beta, gamma, q_init, penalty)
    check_seed(seed)
    check_stream_seeds(seed)
    base.check_limits(time_limit, memory_limit)
    mdp_mod.check_reward_units(reward_units)
    if not isinstance(slot_in_state, bool):
        raise OptionError(f"slot_in_state: must be true or false, got {slot_in_state!r}")
    method = METHOD_OF_REWARD[reward]
    if instance.fleet:
        _require_fleet_memory(instance, memory_limit)
        build, slots, train_fn, rollout_fn = fleet_mdp.build, fleet_kernels.FLEET_SLOTS, fleet_kernels.train, fleet_kernels.rollout
    else:
        base.require_memory(mdp_bytes(instance), memory_limit, "the MDP's tables")
        build, slots, train_fn, rollout_fn = mdp_mod.build, 1 << 15, train, rollout
    startup_s = warm_up(bool(instance.fleet))
    settings = {"reward": reward, "reward_units": reward_units, "episodes": episodes, "seed": seed, "beta": beta,
                "gamma": gamma, "epsilon0": 1.0 / episodes, "q_init": q_init, "penalty": penalty,
                "slot_in_state": slot_in_state, "memory_limit_gb": memory_limit, "startup_s": startup_s}
    if is_lossy(instance):  # MODEL.md 11: outcomes drawn (qlearning/lossy.py); the lossless path below is untouched
        from voiopt.solvers.qlearning import lossy

        options = dict(progress=progress, episodes=episodes, seed=seed, beta=beta, gamma=gamma, q_init=q_init,
                       penalty=penalty, time_limit=time_limit, memory_limit=memory_limit, slot_in_state=slot_in_state,
                       reward_units=reward_units, settings=settings, samples=samples, ir_samples=ir_samples)
        return lossy.solve_lossy(instance, objective, reward, method, options, lambda plain: _run(
            plain, objective, reward, **{k: v for k, v in options.items() if k != "settings"}))
    with watch(time_limit, memory_limit) as stop:
        try:
            model = build(instance, reward, penalty, slot_in_state, reward_units, stop=stop)
        except joint.NoJointPlan as e:  # proven: no legal plan to learn
            return Result.from_plan(instance, method, objective, None, status=Status.INFEASIBLE, runtime_s=stop.elapsed(),
                                    solver={**settings, "episodes_run": 0, "note": str(e)})
        except Stopped:  # nothing learnt: the plan of a stopped heuristic (no uploads, robots heading home)
            from voiopt.solvers.baselines.heuristics import stopped_result

            return stopped_result(instance, method, objective, stop, {**settings, "episodes_run": 0},
                                  "stopped while building the MDP's tables")
        held = float(getattr(model, "alive", np.empty(0)).nbytes)  # a fleet's joint mask counts against the limit too
        table = QTable(model, q_init, None if stop.memory_bytes is None else max(stop.memory_bytes - held, 1.0),
                       slots=slots)
        eps = np.array([1.0])
        eps0 = settings["epsilon0"]
        rng = np.array([seed_state(seed)], dtype=np.uint64)
        T = instance.horizon
        # chunks in episodes, sized in steps (one episode at T = 10^6 is about 0.1 s), and a step
        # weighs its joint actions: each step of a fleet scans them (4 robots: 50,625, 300 us a step)
        work = T * max(1, model.max_actions // ACTIONS_PER_STEP)
        done, chunk = 0, max(FIRST_STEPS // work, 1)
        columns = (text_column("eps {task.fields[eps]:.3f}"), text_column("greedy {task.fields[greedy]}"),
                   text_column("states {task.fields[states]}"))
        with progress_bar(progress, *columns) as bar:
            label = method if reward == Worth.AOI or reward_units == "bit/s" else f"{method} {reward_units}"  # two readings apart
            task = bar.add_task(label, total=episodes, eps=1.0, greedy="-", states=0)
            while done < episodes:
                n = min(chunk, episodes - done)
                c0 = time.perf_counter()
                ran, fits = train_fn(model, table, n, eps, eps0, beta, gamma, rng)
                done += ran
                elapsed = time.perf_counter() - c0
                chunk = max(int(min(max(chunk * min(4.0, 0.25 / max(elapsed, 1e-3)), MIN_STEPS // work), MAX_STEPS // work)), 1)
                idx, sched = rollout_fn(model, table)
                value = simulate_indices(instance, idx, sched).metrics[objective]
                bar.update(task, completed=done, eps=max(float(eps[0]), 0.0), greedy=f"{value:.6g}",
                           states=table.n_states)
                if not fits:
                    stop.request(MEMORY_LIMIT)
                if done < episodes and stop.check():  # a request after the last episode changes nothing
                    if progress:
                        bar.console.print(f"[yellow]{method}: {stop.describe()} after {done} of {episodes} "
                                          "episodes; returning the greedy plan so far")
                    break
        table.drop_next()  # a table allocated ahead of a growth that did not come
        idx, sched = rollout_fn(model, table)
    solver = {**settings, "episodes_run": done, "table_states": table.n_states,
              "table_mib": round(table.nbytes / 2**20, 3)}
    if instance.fleet:
        solver.update(robots=instance.n_robots, joint_actions_max=model.max_actions)
    if stop.reason and done < episodes:
        solver["stopped"] = f"{stop.describe()} after {done} of {episodes} episodes ({table.n_states} states)"
    return Result.from_plan(
        instance, method, objective, Plan.from_indices(instance, idx, sched),
        status=(stop.reason if done < episodes else None) or Status.FEASIBLE, runtime_s=stop.elapsed(), solver=solver,
    )


@dataclass(frozen=True)
class Options(options.Options):
    """Q-learning's options (``solve``'s and ``solve_aoi``'s keywords)."""

    episodes: int = EPISODES
    seed: int = 0
    beta: float = BETA
    gamma: float = GAMMA
    q_init: float = 0.0
    penalty: float = mdp_mod.IDLE_PENALTY
    slot_in_state: bool = False
    reward_units: str = "bit/s"
    samples: int = DEFAULT_SAMPLES  # lossy links: coupled scenarios of a Monte Carlo value
    ir_samples: int = 0  # lossy links: scenarios of the information-relaxation bound (0: none)

def solve(instance: Instance, objective: str = DEFAULT, *, progress: bool = False,
          episodes: int = EPISODES, seed: int = 0, beta: float = BETA, gamma: float = GAMMA,
          q_init: float = 0.0, penalty: float = mdp_mod.IDLE_PENALTY, time_limit: float | None = None,
          memory_limit: float = base.DEFAULT_MEMORY_GB, slot_in_state: bool = False, reward_units: str = "bit/s",
          samples: int = DEFAULT_SAMPLES, ir_samples: int = 0) -> Result:
    """The paper's "VoI-optimal" scheme: Algorithm 1 with reward min_i V_i - idle penalty.

    Options default to the paper's values: V in bit/s and a penalty of 100 (MODEL.md section 7);
    ``reward_units="bit/s/Hz"`` divides V by B, for comparison. ``memory_limit`` (GB) bounds
    the Q-table. ``slot_in_state=True`` (not the paper's) adds t to the state; with gamma=1 and
    penalty=0 Q-learning then targets exactly T * mean-min-voi (in reward units). On lossy
    links (MODEL.md 11) it learns from sampled outcomes and returns its greedy policy, valued
    exactly or by Monte Carlo over ``samples`` scenarios, bounded (``ir_samples``: the
    information relaxation); see qlearning/lossy.py."""
    return _run(instance, objective, "voi", **_options(locals()))


def solve_aoi(instance: Instance, objective: str = AOI_DEFAULT, *, progress: bool = False,
              episodes: int = EPISODES, seed: int = 0, beta: float = BETA, gamma: float = GAMMA,
              q_init: float = 0.0, penalty: float = mdp_mod.IDLE_PENALTY,
              time_limit: float | None = None, memory_limit: float = base.DEFAULT_MEMORY_GB,
              slot_in_state: bool = False, reward_units: str = "bit/s", samples: int = DEFAULT_SAMPLES,
              ir_samples: int = 0) -> Result:
    """The paper's "AoI-optimal" scheme: Algorithm 1 with reward -max_i A_i - idle penalty.

    The AoI reward has no units to choose; ``reward_units`` is accepted (and recorded) so that
    a sweep can pass one setting to both Q-learning schemes."""
    return _run(instance, objective, "aoi", **_options(locals()))


def _options(arguments: dict) -> dict:
    """A scheme's keyword options, from its arguments."""
    return {k: v for k, v in arguments.items() if k not in ("instance", "objective")}
