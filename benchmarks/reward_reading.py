"""How the reading of the paper's reward changes the certified gap of its Q-learning.

MODEL.md section 7: r = min_i V_i - f_penalty with f_penalty = 100 if no upload. The paper
writes V in bit/s (the default, ``reward_units="bit/s"``); an earlier reading divided V by B
(``"bit/s/Hz"``), which makes the penalty swamp every VoI. For the shipped case study and
networks from the paper's generator (N = 4, T = 30, rho ~ U(0, 1)) this prints, for both
readings, the gap of Q-learning's plan to the dp optimum over K seeds: mean, min and max.

Usage:
    python benchmarks/reward_reading.py                    # case study + 6 networks, 3 seeds, 1e6 episodes
    python benchmarks/reward_reading.py --networks 2 --seeds 2 --episodes 100000   # a quick look
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import voiopt

ROOT = Path(__file__).resolve().parent.parent
READINGS = ("bit/s", "bit/s/Hz")


def _pct(v: float) -> str:
    return f"{100 * v:.1f} %"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--networks", type=int, default=6, help="paper-scale networks besides the case study")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--episodes", type=int, default=1_000_000)
    ap.add_argument("--seed", type=int, default=1, help="generator seed of the networks")
    args = ap.parse_args()

    nets = [voiopt.load(ROOT / "instances" / "case-study.json")]
    nets += voiopt.generate_set(args.networks, seed=args.seed, n_sensors=4, horizon=30, rho=(0.0, 1.0))
    print(f"Q-learning, {args.episodes} episodes, seeds 0..{args.seeds - 1}; gap to the dp optimum "
          f"(mean over seeds, [min, max]); objective mean-min-voi")
    print("| network | dp optimum (bit/s) | gap, bit/s reading (the paper's) | gap, bit/s/Hz reading |")
    print("|---|---:|---:|---:|")
    all_gaps = {r: [] for r in READINGS}
    t0 = time.perf_counter()
    for inst in nets:
        opt = voiopt.solve(inst, method="dp", objective="mean-min-voi")
        assert opt.status == "optimal", opt.summary()
        cells = []
        for reading in READINGS:
            gaps = []
            for seed in range(args.seeds):
                r = voiopt.solve(inst, method="qlearning", objective="mean-min-voi", seed=seed,
                                 episodes=args.episodes, reward_units=reading)
                gaps.append((opt.value - r.value) / opt.value)
            all_gaps[reading] += gaps
            cells.append(f"{_pct(statistics.fmean(gaps))} [{_pct(min(gaps))}, {_pct(max(gaps))}]")
        print(f"| {inst.name} | {opt.value:.6g} | {cells[0]} | {cells[1]} |", flush=True)
    cells = [f"{_pct(statistics.fmean(g))} [{_pct(min(g))}, {_pct(max(g))}]" for g in all_gaps.values()]
    print(f"| all {len(nets)} networks x {args.seeds} seeds | | {cells[0]} | {cells[1]} |")
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    import report

    sys.exit(report.run("reward_reading", main))
