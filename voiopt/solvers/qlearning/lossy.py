"""Q-learning on lossy links (MODEL.md sections 7 and 11): Algorithm 1 learning from sampled
outcomes (kernels.train with a success table), and its policy.

Its policy is the greedy policy of its table: in an observed state, the first feasible action
of largest Q-value. The table's state holds each sensor's distance as the point it uploaded
from (or its initial distance); an observed distance is matched to the states it can stand
for, the first held by the table in the order initial distance, then lattice points by index.
A state the table never visited gets voiopt.core.policy's stated fallback (the legal action of
largest expected next reward). Its value is exact where the states it reaches can be
enumerated, else Monte Carlo over coupled scenarios with a 95 % CI; its bound is the lossless
optimum's proven bound (dp on the instance without links), or with ``ir_samples`` the
information relaxation capped by it.

Fleets on lossy links are not learnt here: their Q-learning solves the lossless problem and
its plan is valued exactly (voiopt.solvers.lossy_plans).
"""

from __future__ import annotations

import itertools
import time

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.links import success_table, without_links
from voiopt.core.policy import Policy
from voiopt.core.policy_value import DEFAULT_SAMPLES, follow_on, value_under
from voiopt.mdp import robot as mdp_mod
from voiopt.runtime.progress import progress_bar, text_column
from voiopt.runtime.status import STOPPED, Status
from voiopt.runtime.stop import MEMORY_LIMIT, Stopped, watch
from voiopt.solvers.qlearning.kernels import q_row, train
from voiopt.solvers.qlearning.rng import seed_state
from voiopt.solvers.qlearning.table import QTable

EXACT_STATES = 20_000  # states of a slot up to which the learnt policy's value is exact
CHUNK_EPISODES = 2000


class QPolicy(Policy):
    """The greedy policy of a trained Q-table; decisions asked for are kept in ``table``."""

    def __init__(self, instance: Instance, objective: str, method: str, model, qtable) -> None:
        super().__init__(instance, objective, method, table={})
        self.model, self.qtable = model, qtable
        self.visited = 0  # decisions taken from the learnt table (the rest: the fallback)
        self.unvisited = 0
        lat = self.steps.lat
        self.candidates = []  # per sensor: {distance rounded: [qidx, ...]}
        for i in range(instance.n_sensors):
            c: dict = {}
            c.setdefault(round(instance.initial_distance(i), 9), []).append(0)
            for p in np.flatnonzero(lat.in_range[i]).tolist():
                c.setdefault(round(float(lat.distance[i, p]), 9), []).append(1 + p)
            self.candidates.append(c)

    def missing(self, t: int, state: tuple, key: tuple) -> tuple[int, int]:
        hit = self.table[key] = self._greedy(t, state)
        return hit

    def _greedy(self, t: int, state: tuple) -> tuple[int, int]:
        p, k, ages, qs = state
        m = self.model
        slot = t if m.slot_in_state else 0
        moves = k if m.moves_in_state else 0
        options = [self.candidates[i].get(round(q, 9), []) for i, q in enumerate(qs)]
        for qidx in itertools.product(*options):
            row = None if self.qtable is None else q_row(m, self.qtable, (p, ages, qidx, slot, moves))
            if row is None:
                continue
            feasible = m.feasible((p, ages, qidx, slot, moves), t)
            values = np.where(feasible, np.asarray(row), -np.inf)
            a = int(np.argmax(values))
            if not feasible[a]:
                break
            self.visited += 1
            u, move = int(m.action_upload[p, a]), int(m.action_move[p, a])
            return u, (0 if t == self.steps.T - 1 else move)
        self.unvisited += 1
        return self.fallback(t, state)


def run(instance: Instance, objective: str, reward: str, method: str, *, progress: bool, episodes: int, seed: int,
        beta: float, gamma: float, q_init: float, penalty: float, time_limit: float | None, memory_limit: float,
        slot_in_state: bool, reward_units: str, settings: dict, samples: int = DEFAULT_SAMPLES,
        ir_samples: int = 0):
    """Train on sampled outcomes; return the greedy policy's Result (value evaluated, bound).
    One stop rule (time limit, memory limit, Ctrl-C) holds for the training, the evaluation and
    the bound's solves; the status names the limit that cut any of them short."""
    from voiopt.solvers.policy.relaxation import policy_bound
    from voiopt.solvers.policy.report import policy_result
    from voiopt.solvers.policy.solver import check_averaged, lossless_optimum

    check_averaged(objective, method)
    settings = {**settings, "startup_s": settings.get("startup_s", 0.0) + warm_up()}
    t0 = time.perf_counter()
    with watch(time_limit, memory_limit) as stop:
        done = 0
        try:
            model = mdp_mod.build(instance, reward, penalty, slot_in_state, reward_units, stop=stop)
        except Stopped:
            model = None
        if model is not None:
            table = QTable(model, q_init, stop.memory_bytes)
            succ = success_table(instance)
            eps, eps0 = np.array([1.0]), 1.0 / episodes
            rng = np.array([seed_state(seed)], dtype=np.uint64)
            with progress_bar(progress, text_column("states {task.fields[states]}")) as bar:
                task = bar.add_task(f"{method} (lossy)", total=episodes, states=0)
                while done < episodes:
                    ran, fits = train(model, table, min(CHUNK_EPISODES, episodes - done), eps, eps0, beta, gamma,
                                      rng, succ)
                    done += ran
                    bar.update(task, completed=done, states=table.n_states)
                    if not fits:
                        stop.request(MEMORY_LIMIT)
                    if done < episodes and stop.check():
                        break
            table.drop_next()
        else:
            table = None
        cuts = [(stop.reason, f"{stop.describe()} after {done} of {episodes} episodes")] if done < episodes else []
        solver = {**settings, "episodes_run": done, "table_states": 0 if table is None else table.n_states,
                  "links": "outcomes drawn"}
        if model is None:
            model = mdp_mod.build(instance, reward, penalty, slot_in_state, reward_units)
        policy = QPolicy(instance, objective, method, model, table)
        evaluation, cut, note = value_under(stop, policy, objective, samples, seed, EXACT_STATES)
        if cut:
            cuts.append((cut, note))
        elif note:
            solver["evaluation_note"] = note
        solver["decisions"] = {"from_table": policy.visited, "fallback": policy.unvisited}
        base = lossless_optimum(instance, objective, follow_on(stop), memory_limit)
        if base.status in STOPPED:
            cuts.append((base.status, f"the lossless bound's dp: {base.status}, its proven bound kept"))
        solver["lossless_bound"] = base.bound
        bound, kind, extra, ir = policy_bound(instance, objective, base.bound, seed=seed, stop=stop,
                                              ir_samples=0 if stop.check() else ir_samples)
        if ir is not None:
            solver["information_relaxation"] = ir
    if cuts:
        solver["stopped"] = "; ".join(why for _, why in cuts)
    return policy_result(instance, method, objective, policy, evaluation, status=cuts[0][0] if cuts else Status.FEASIBLE,
                         bound=bound, bound_kind=kind, runtime_s=time.perf_counter() - t0, solver=solver, **extra, stop=stop)


def warm_up() -> float:
    """Compile (or load) the lossy kernel once per process, on a tiny lossy MDP."""

    def load():
        from voiopt.core.instance import from_dict
        from voiopt.networks.generate import generate

        tiny = from_dict(generate(1, 2, width=1.0, height=1.0, seed=0, name="warm-up").to_dict()
                         | {"links": {"model": "bernoulli", "success": 0.5}})
        model = mdp_mod.build(tiny)
        table = QTable(model, 0.0, 64 * 2**20)
        train(model, table, 1, np.array([1.0]), 1.0, 0.75, 0.9, np.array([1], dtype=np.uint64),
              success_table(tiny))

    from voiopt.solvers import base

    return base.warm_up_once("qlearning-lossy", load)


def solve_lossy(instance: Instance, objective: str, reward: str, method: str, options: dict, lossless_run):
    """Q-learning on a lossy instance: one robot learns from sampled outcomes (``run``) for an
    averaged objective. A fleet, or a bottleneck objective (whose policy would need the running
    extreme in its state, MODEL.md 11), gets what every plan method gets: the lossless
    problem's plan (``lossless_run(instance without links)``), open-loop, valued exactly, with
    the lossless bound where the run has one."""
    if instance.fleet or not objectives.get(objective).per_slot:
        from voiopt.solvers.lossy_plans import plan_result

        result = plan_result(instance, lossless_run(without_links(instance)), options)
        result.solver["policy"] = ("none: the lossless plan, open-loop (Q-learning learns from outcomes for one "
                                   "robot and an averaged objective)")
        return result
    return run(instance, objective, reward, method, **options)
