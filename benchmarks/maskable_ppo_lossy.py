"""MaskablePPO (sb3-contrib) trained on a lossy instance, its greedy policy valued and
certified like voiopt's own policies (docs/policy.md, "MaskablePPO").

The instance: the case study at horizon T with bernoulli links of success p (defaults T = 10,
p = 0.7), where policy-dp gives the exact optimal policy in seconds. MaskablePPO trains on
voiopt.env with the env's action masks and its normalised reward (min_i V_i(t+1) divided by
the optimum without links, no penalty: the episode's sum is the realised run's mean-min-voi
over a constant), the env drawing each upload's outcome from its own seeded generator, for
--steps steps per seed. Its greedy policy (deterministic, masked) is then a function of voiopt's
observation (slot, position, A, q) and is valued by voiopt.evaluate_function: exactly by forward
enumeration where its reachable states are few, else Monte Carlo over the coupled scenarios of
--scenario-seed, the very U(t, i) that Q-learning's, re-planning's and the open-loop plan's
Monte Carlo values use. Beside it: policy-dp's exact optimum (the bound, kind exact), re-planning,
the open-loop dp plan (its exact expectation), Q-learning over the same seeds, and the lossless
bound (dp without links, proven). Writes docs/results/maskable_ppo_lossy.md.

    pip install -e '.[rl,sb3]'   # torch comes with sb3-contrib
    python benchmarks/maskable_ppo_lossy.py [--steps 50000] [--seeds 3] [--paper]

--paper adds the paper-scale network (N = 4, T = 30, generated with seed 3, the same links),
beyond policy-dp: there every policy is certified against the lossless bound only, and
re-planning (a dp solve for each of the thousands of states its runs reach) is left out. torch runs
on one thread (--threads; a thread per core is many times slower for this small network).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time

import numpy as np

import voiopt
from voiopt.core.instance import Instance, from_dict
from voiopt.core.links import without_links
from voiopt.core.policy import Policy
from voiopt.core.policy_value import monte_carlo_value
from voiopt.core.result import BoundKind
from voiopt.core.scenarios import estimate, sample_scenarios
from voiopt.core.steps import MOVE_NAMES
from voiopt.networks.generate import generate
from voiopt.objectives import gap

OBJECTIVE = "mean-min-voi"


class GreedyPPO:
    """A trained MaskablePPO as a function of voiopt's observation: the env's observation and
    the legal actions' mask built from it, the deterministic action read back as (sensor, move)."""

    def __init__(self, model, env, instance: Instance) -> None:
        self.model, self.instance = model, instance
        self.reader = Policy(instance, OBJECTIVE, "observation", table={})  # parses observations, knows the legal moves
        self.steps = self.reader.steps
        self.max_age = float(max(s.initial_aoi for s in instance.sensors) + instance.horizon)  # voiopt.env's scales
        self.diagonal = float(np.hypot(instance.width, instance.height))
        self.check(env)

    def env_observation(self, observation: dict) -> dict[str, np.ndarray]:
        inst = self.instance
        return {"position": (np.asarray(observation["position"]) / [inst.width, inst.height]).astype(np.float32),
                "aoi": np.clip(np.asarray(observation["aoi"]) / self.max_age, 0, 1).astype(np.float32),
                "q": np.clip(np.asarray(observation["distance"]) / self.diagonal, 0, 1).astype(np.float32),
                "slot": np.array([observation["slot"] / inst.horizon], dtype=np.float32)}

    def mask(self, observation: dict) -> np.ndarray:
        """The env's mask over its Discrete numbers (upload + 1) * 5 + move, from voiopt's legal
        actions: in the last slot every move on the area (the env offers them; p(T) is not part of
        a plan, so the move is then read as "stay")."""
        t, state = self.reader.observed(observation)
        p, lat = state[0], self.steps.lat
        last = t == self.instance.horizon - 1
        moves = [m for m in range(5) if lat.neighbors[p, m] >= 0] if last else [m for m, _, _ in self.steps.moves(t, p, state[1])]
        mask = np.zeros((self.instance.n_sensors + 1) * 5, dtype=bool)
        for u in [-1, *self.steps.in_range[p]]:
            mask[[(u + 1) * 5 + m for m in moves]] = True
        return mask

    def __call__(self, observation: dict) -> tuple[int | None, str]:
        a, _ = self.model.predict(self.env_observation(observation), action_masks=self.mask(observation),
                                  deterministic=True)
        a = int(a)
        move = "stay" if observation["slot"] == self.instance.horizon - 1 else MOVE_NAMES[a % 5]
        return (None if a < 5 else a // 5 - 1), move

    def check(self, env) -> None:
        """The observations and masks built here are the env's own, slot by slot, over one greedy
        episode (else the policy valued would not be the policy trained)."""
        base = env.unwrapped
        obs, _ = base.reset(seed=0)
        for t in range(self.instance.horizon):
            p, aoi, qidx, *_ = base.state
            lat = base.lattice
            dist = [self.instance.initial_distance(i) if q == 0 else float(lat.distance[i, q - 1])
                    for i, q in enumerate(qidx)]
            observation = {"slot": t, "position": lat.points[p].tolist(), "aoi": list(aoi), "distance": dist,
                           "moves_used": int(base.state[-1])}
            mine = self.env_observation(observation)
            for key, value in obs.items():
                if not np.allclose(value, mine[key], atol=1e-6):
                    raise SystemExit(f"slot {t}: the env's observation {key} {value} is not the one built here {mine[key]}")
            if not np.array_equal(base.action_masks(), self.mask(observation)):
                raise SystemExit(f"slot {t}: the env's action mask is not the one built here")
            a, _ = self.model.predict(obs, action_masks=base.action_masks(), deterministic=True)
            obs, *_ = base.step(int(a))


def rollouts(model, env, episodes: int):
    """The trained policy's own mean-min-voi in the env (greedy, the env's masks and outcome
    draws), over ``episodes`` episodes: an estimate of the value computed from voiopt's side."""
    base = env.unwrapped
    values = []
    for k in range(episodes):
        obs, _ = base.reset(seed=10_000 + k)
        total, done = 0.0, False
        while not done:
            a, _ = model.predict(obs, action_masks=base.action_masks(), deterministic=True)
            obs, r, done, _, _ = base.step(int(a))
            total += r
        values.append(total * base.optimum() / base.instance.horizon)
    return estimate(values)


def train(instance: Instance, steps: int, seed: int):
    from sb3_contrib import MaskablePPO
    from sb3_contrib.common.wrappers import ActionMasker

    import voiopt.env as voienv

    env = ActionMasker(voienv.VoIEnv(instance, reward_mode="normalised"), lambda e: e.unwrapped.action_masks())
    model = MaskablePPO("MultiInputPolicy", env, seed=seed, verbose=0)
    model.learn(total_timesteps=steps)
    return model, env


def on_shared_scenarios(r, instance: Instance, args):
    """``r`` itself where its value is exact or already over the shared scenarios; else its policy
    valued again over them (Q-learning draws its scenarios from its training seed)."""
    if r.evaluation != "monte-carlo" or r.solver.get("scenario_seed") == args.scenario_seed:
        return r
    est = monte_carlo_value(r.policy, sample_scenarios(instance, args.samples, args.scenario_seed))
    return dataclasses.replace(r, value=est.mean, value_ci=est.ci, samples=est.count,
                               solver=r.solver | {"scenario_seed": args.scenario_seed})


def cell(r) -> str:
    """A value as evaluated: exact, or the Monte Carlo mean with its 95 % CI and sample count."""
    if r.evaluation == "monte-carlo":
        lo, hi = r.value_ci
        return f"{r.value:.6g} ± {(hi - lo) / 2:.3g} (MC, {r.samples}, seed {r.solver['scenario_seed']})"
    return f"{r.value:.6g} (exact)"


def pct(value: float, bound: float | None) -> str:
    g = gap(value, bound)
    return "-" if g is None else f"{100 * g:.1f} %"


def network(name: str, inst: Instance, args, exact: bool) -> list[str]:
    """The table rows of one network: every method, and MaskablePPO per seed and over seeds."""
    mc = {"samples": args.samples, "seed": args.scenario_seed}
    lossless = voiopt.solve(without_links(inst), "dp", OBJECTIVE).bound
    best = voiopt.solve(inst, "policy-dp", OBJECTIVE) if exact else None
    if best is not None and best.bound_kind != BoundKind.EXACT:
        raise SystemExit(f"{name}: policy-dp stopped ({best.status}); run without it (drop the network)")
    bound, kind = (best.value, BoundKind.EXACT) if best is not None else (lossless, BoundKind.LOSSLESS)
    rows = []

    def row(method: str, seed: str, r, seconds: float | None = None, env=None) -> None:
        own = "-" if env is None else f"{env.mean:.6g} [{env.ci[0]:.6g}, {env.ci[1]:.6g}]"
        rows.append(f"| {name} | {method} | {seed} | {cell(r)} | {pct(r.value, bound) if exact else '-'} | "
                    f"{pct(r.value, lossless)} | {own} | {'-' if seconds is None else f'{seconds:.0f}'} |")
        print(f"  {method} {seed}: {cell(r)}", file=sys.stderr, flush=True)

    if best is not None:
        row("policy-dp (exact optimal policy)", "-", best)
    if exact:  # at paper scale each of its thousands of states would cost a dp solve
        row("replan (dp each slot)", "-", voiopt.solve(inst, "replan", OBJECTIVE, **mc))
    row("open-loop dp plan", "-", voiopt.solve(inst, "dp", OBJECTIVE))
    summary = {}
    for label, runs in (("qlearning", []), ("MaskablePPO", [])):
        for seed in range(args.seeds):
            t0, own = time.perf_counter(), None
            if label == "qlearning":
                r = voiopt.solve(inst, "qlearning", OBJECTIVE, episodes=args.episodes, seed=seed, samples=args.samples)
                r = on_shared_scenarios(r, inst, args)
            else:
                model, env = train(inst, args.steps, seed)
                act = GreedyPPO(model, env, inst)
                r = voiopt.evaluate_function(inst, OBJECTIVE, act, method="maskable-ppo", bound=bound,
                                             bound_kind=kind, samples=args.samples, seed=args.scenario_seed)
                own = rollouts(model, env, args.rollouts)
            runs.append(r)
            row(f"{label} ({args.episodes:g} episodes)" if label == "qlearning" else f"{label} ({args.steps:g} steps)",
                str(seed), r, time.perf_counter() - t0, own)
        summary[label] = [r.value for r in runs]
    for label, values in summary.items():
        mean = statistics.mean(values)
        spread = (f"{pct(mean, bound)} [{pct(max(values), bound)}, {pct(min(values), bound)}]" if exact else "-")
        rows.append(f"| {name} | {label}: mean [min, max] over {len(values)} seeds | - | {mean:.6g} "
                    f"[{min(values):.6g}, {max(values):.6g}] | {spread} | {pct(mean, lossless)} "
                    f"[{pct(max(values), lossless)}, {pct(min(values), lossless)}] | - | - |")
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=50_000, help="MaskablePPO's training steps per seed")
    ap.add_argument("--seeds", type=int, default=3, help="training seeds of MaskablePPO and Q-learning")
    ap.add_argument("--episodes", type=int, default=100_000, help="Q-learning's episodes per seed")
    ap.add_argument("--horizon", type=int, default=10)
    ap.add_argument("--success", type=float, default=0.7, help="bernoulli links' success probability")
    ap.add_argument("--samples", type=int, default=1000, help="Monte Carlo scenarios where a value is not exact")
    ap.add_argument("--scenario-seed", type=int, default=0, help="the coupled scenarios' seed, shared by every method")
    ap.add_argument("--threads", type=int, default=1, help="torch's threads")
    ap.add_argument("--rollouts", type=int, default=300, help="episodes of each trained policy in the env itself")
    ap.add_argument("--paper", action="store_true", help="also the paper-scale network (N = 4, T = 30): lossless bound")
    args = ap.parse_args()
    for name in ("steps", "seeds", "episodes", "horizon", "samples", "threads", "rollouts"):
        if getattr(args, name) < 1:
            raise SystemExit(f"--{name}: must be an integer >= 1, got {getattr(args, name)}")
    try:
        import torch
        from sb3_contrib import MaskablePPO  # noqa: F401
    except ImportError:
        raise SystemExit("maskable_ppo_lossy.py needs sb3-contrib and torch: pip install -e '.[rl,sb3]'") from None
    torch.set_num_threads(args.threads)
    links = {"model": "bernoulli", "success": args.success}
    cases = [(f"case study (N=3, T={args.horizon})", from_dict(voiopt.load("instances/case-study.json").to_dict()
                                                            | {"horizon": args.horizon, "links": links}), True)]
    if args.paper:
        cases.append(("paper seed 3 (N=4, T=30)", from_dict(generate(4, 30, seed=3, name="paper").to_dict()
                                                             | {"links": links}), False))
    print(f"# MaskablePPO on lossy links: {OBJECTIVE}, bernoulli links of success {args.success:g}")
    print()
    print(f"MaskablePPO: sb3-contrib's defaults, {args.steps:g} steps per seed, seeds 0-{args.seeds - 1}, torch threads "
          f"{torch.get_num_threads()}; reward min_i V_i(t+1) / lossless optimum (voiopt.env, normalised), action masks; "
          "its greedy policy valued by voiopt.evaluate_function. Q-learning: voiopt solve --method qlearning, "
          f"{args.episodes:g} episodes per seed. Values exact where the policy's reachable states are few, else "
          f"Monte Carlo (± half the 95 % CI, scenarios) over the coupled scenarios of seed {args.scenario_seed}, the "
          "same for every method. Gaps: to policy-dp's exact optimal value (bound kind exact) and to the lossless "
          "bound (dp without links, proven). The env's own rollouts: the trained policy run greedily in the env "
          f"(its masks, its outcome draws) for {args.rollouts} episodes, mean and 95 % CI of the realised mean-min-voi: "
          "a check, from the training side, of the value computed by voiopt. Seconds: training and evaluation.")
    print()
    print("| network | method | seed | expected value | gap to the exact optimum | gap to the lossless bound | "
          "the env's own rollouts | seconds |")
    print("|---|---|---|---|---|---|---|---|")
    for name, inst, exact in cases:
        for line in network(name, inst, args, exact):
            print(line, flush=True)
    return 0


if __name__ == "__main__":
    import report

    sys.exit(report.run("maskable_ppo_lossy", main))
