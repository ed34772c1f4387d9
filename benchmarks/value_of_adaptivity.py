"""The value of adaptivity on the case study under bernoulli links: the optimal policy
(policy-dp, exact), re-planning (replan, dp each slot), Q-learning (Algorithm 1 learning from
outcomes, over seeds: mean, min, max) and the open-loop lossless optimum plan (dp's plan,
exact expectation), against the success probability, for ``mean-min-voi``. Every value is
exact (forward enumeration of the policy's outcomes, or the plan's exact expectation);
Q-learning's is exact per seed where its states can be enumerated, else Monte Carlo (said in
the table). Writes docs/results/value_of_adaptivity.md.

    python benchmarks/value_of_adaptivity.py [--horizon 10] [--episodes 100000] [--seeds 3]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import voiopt
from voiopt.core.instance import from_dict


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--horizon", type=int, default=10)
    ap.add_argument("--episodes", type=int, default=100_000)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--success", type=float, nargs="+", default=[1.0, 0.9, 0.7, 0.5, 0.3])
    ap.add_argument("--objective", default="mean-min-voi")
    args = ap.parse_args()
    base = voiopt.load("instances/case-study.json").to_dict() | {"horizon": args.horizon}
    rows = []
    for p in args.success:
        inst = from_dict(base | {"links": {"model": "bernoulli", "success": p}})
        opt = voiopt.solve(inst, "policy-dp", args.objective)
        replan = voiopt.solve(inst, "replan", args.objective)
        plan = voiopt.solve(inst, "dp", args.objective)
        q = [voiopt.solve(inst, "qlearning", args.objective, episodes=args.episodes, seed=s) for s in range(args.seeds)]
        qv = [r.value for r in q]
        how = sorted({r.evaluation or "exact" for r in q})
        rows.append((p, opt, replan, plan, qv, "/".join(how)))
        print(f"p = {p}: done", file=sys.stderr, flush=True)  # progress, not the table
    lines = [
        f"# Value of adaptivity: case study, T = {args.horizon}, {args.objective}, bernoulli links",
        "",
        "Made by `python benchmarks/value_of_adaptivity.py "
        f"--horizon {args.horizon} --episodes {args.episodes} --seeds {args.seeds}`. Every value is an expected "
        "objective: the optimal policy's and re-planning's exact (forward enumeration of their outcomes), the "
        "open-loop plan's exact (its expectation), Q-learning's as its evaluation column says. Percentages are of "
        "the optimal policy's value; the lossless bound is dp's proven optimum without links.",
        "",
        "| success p | optimal policy (policy-dp) | re-planning (replan) | open-loop plan (dp) | "
        f"Q-learning mean [min, max] over {args.seeds} seeds | Q-learning evaluation | lossless bound |",
        "|---|---|---|---|---|---|---|",
    ]
    for p, opt, replan, plan, qv, how in rows:
        def pct(v, ref=opt.value):
            return f"{v:.6g} ({100 * v / ref:.1f} %)"

        mean = sum(qv) / len(qv)
        lines.append(f"| {p:g} | {opt.value:.6g} ({opt.status}) | {pct(replan.value)} | {pct(plan.value)} | "
                     f"{pct(mean)} [{min(qv):.6g}, {max(qv):.6g}] | {how} | {opt.solver['lossless']['bound']:.6g} |")
    print("\n".join(lines))
    _figure(rows, args)


def _figure(rows, args) -> None:
    """docs/figures/value_of_adaptivity.png: each policy's expected value against p."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from voiopt.runtime.files import atomic_write

    ps = [r[0] for r in rows]
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(ps, [r[1].value for r in rows], "o-", label="optimal policy (policy-dp, exact)")
    ax.plot(ps, [r[2].value for r in rows], "s--", label="re-planning (replan, exact)")
    ax.plot(ps, [r[3].value for r in rows], "^:", label="open-loop plan (dp's lossless optimum)")
    q = [(sum(r[4]) / len(r[4]), min(r[4]), max(r[4])) for r in rows]
    ax.errorbar(ps, [m for m, _, _ in q], yerr=[[m - lo for m, lo, _ in q], [hi - m for m, _, hi in q]], fmt="d-",
                capsize=3, label=f"Q-learning ({args.episodes:g} episodes, {args.seeds} seeds: mean, min-max)")
    ax.axhline(rows[0][1].solver["lossless"]["bound"], color="grey", lw=0.8, ls="-.", label="lossless optimum (bound)")
    ax.set_xlabel("upload success probability p (bernoulli links)")
    ax.set_ylabel(f"expected {args.objective} (bit/s)")
    ax.set_title(f"Value of adaptivity: case study, T = {args.horizon}")
    ax.invert_xaxis()
    ax.legend(fontsize=7)
    fig.tight_layout()
    out = Path(__file__).resolve().parent.parent / "docs" / "figures" / "value_of_adaptivity.png"
    with atomic_write(out, binary=True) as f:
        fig.savefig(f, format="png", dpi=150)
    plt.close(fig)


if __name__ == "__main__":
    import report

    sys.exit(report.run("value_of_adaptivity", main))
