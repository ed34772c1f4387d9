"""Train sb3-contrib's MaskablePPO on VoI-Lib instances and print its certified gap.

    pip install -e '.[rl,sb3]'          # CPU only: first pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu
    python examples/maskable_ppo.py --steps 100000

The policy sees the env's Dict observation and its action masks; the reward is the per-slot
min-VoI normalised by each instance's certified optimum, with no idle penalty (voiopt.env,
reward_mode="normalised"). Training draws one of the VoI-Lib instances of the chosen group at
every episode; afterwards each is rolled out greedily (with masks), its plan is simulated, and
its gap to the certificate is printed, as `voiopt bench score` would.

torch runs on one thread by default (--threads): its default, one thread per core, makes the
small policy network's many tiny matrix products fight over the cores; on a 2-core machine
20,000 steps took 8 min 26 s with torch's default and 30 s with one thread.
"""

from __future__ import annotations

import argparse
import statistics

import gymnasium as gym
import numpy as np

import voiopt.env as voienv
from voiopt.objectives import gap
from voiopt.solvers.dp import solver as dp
from voiopt.voilib import library as voilib


class PickInstance(gym.Wrapper):
    """At every reset, one of ``instances`` at random (the env's own generator)."""

    def __init__(self, env, instances):
        super().__init__(env)
        self.instances = instances

    def reset(self, *, seed=None, options=None):
        if seed is not None:
            self.env.reset(seed=seed)  # seeds the env's generator, which then picks
        k = int(self.env.unwrapped.np_random.integers(len(self.instances)))
        return self.env.reset(options={"instance": self.instances[k]})


def main() -> int:
    try:
        from sb3_contrib import MaskablePPO
        from sb3_contrib.common.wrappers import ActionMasker
    except ImportError:  # the example's own extra: one line, not a traceback
        raise SystemExit("maskable_ppo.py needs sb3-contrib and torch: pip install -e '.[rl,sb3]' "
                         "(see the top of this file)") from None

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=100_000, help="training steps (default 100000)")
    ap.add_argument("--group", default="paper-n4-t30", help="VoI-Lib instances whose names start so")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1,
                    help="torch's threads (default 1: a small policy network runs fastest on one)")
    args = ap.parse_args()
    if args.threads < 1:
        raise SystemExit(f"--threads: must be an integer >= 1, got {args.threads}")
    import torch  # installed with sb3-contrib

    torch.set_num_threads(args.threads)

    lib = voilib.instances()
    names = [n for n in lib if n.startswith(args.group)]
    insts = [lib[n] for n in names]
    if not insts:
        raise SystemExit(f"--group: no VoI-Lib instances named {args.group}*")
    optima = []
    for inst in insts:  # the certificate, or dp's proven optimum where the certificate is an interval
        opt = voilib.certified(inst, "mean-min-voi")
        if opt is None:
            r = dp.solve(inst, "mean-min-voi")
            if r.status != "optimal":
                raise SystemExit(f"{inst.name}: no certified optimum to measure a gap against")
            opt = r.value
        optima.append(opt)
    base = voienv.VoIEnv(insts[0], reward_mode="normalised")
    env = ActionMasker(PickInstance(base, insts), lambda e: e.unwrapped.action_masks())
    model = MaskablePPO("MultiInputPolicy", env, seed=args.seed, verbose=0)
    model.learn(total_timesteps=args.steps)

    gaps = []
    print(f"MaskablePPO, {args.steps} steps, seed {args.seed}, torch threads {torch.get_num_threads()}, "
          "reward: min-VoI / certified optimum, no penalty")
    for name, inst, opt in zip(names, insts, optima, strict=True):
        obs, _ = base.reset(options={"instance": inst})
        done = False
        while not done:
            action, _ = model.predict(obs, action_masks=base.action_masks(), deterministic=True)
            obs, _, done, _, _ = base.step(int(action))
        value = voilib.score({"instance": name, "objective": "mean-min-voi", "plan": base.plan().to_dict()})["value"]
        gaps.append(gap(value, opt))
        print(f"  {name}: mean-min-voi {value:.6g} of a certified {opt:.6g}: gap {100 * gaps[-1]:.1f} %")
    print(f"mean certified gap {100 * statistics.mean(gaps):.1f} % (min {100 * min(gaps):.1f} %, "
          f"max {100 * max(gaps):.1f} %) over {len(gaps)} instances")
    return 0 if np.isfinite(gaps).all() else 1


if __name__ == "__main__":
    raise SystemExit(main())
