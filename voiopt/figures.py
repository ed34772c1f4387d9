"""The paper's figures with the proven optimum added, and trajectory plots for any result.

Fig. 3: case-study trajectories; Fig. 4: average VoI over time in the case study;
Figs. 5-7: time-average minimum VoI versus power, heterogeneity and the number of nodes.
Beside each PNG a CSV holds the numbers plotted; figures.md lists them.
"""

from __future__ import annotations

import math
import os
import statistics
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from voiopt import instance as instance_mod
from voiopt import lattice as lattice_mod
from voiopt.errors import OptionError
from voiopt.generate import case_study, generate_set, write_set
from voiopt.instance import Instance, atomic_write
from voiopt.models.mdp import check_reward_units
from voiopt.result import Plan, Result, load_result
from voiopt.simulate import simulate
from voiopt.solvers import RANDOMISED

SCHEMES = {  # method -> label in the paper's words
    "qlearning": "VoI-optimal (Q-learning)",
    "aoi-qlearning": "AoI-optimal (Q-learning)",
    "shortest-path": "shortest path",
    "dp": "proven optimum (dp)",
}
COLOURS = {"qlearning": "tab:blue", "aoi-qlearning": "tab:orange", "shortest-path": "tab:green", "dp": "black"}
OBJECTIVE = "mean-min-voi"


def start_figure(nrows: int = 1, ncols: int = 1, figsize=(5.0, 4.0)):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(nrows, ncols, figsize=figsize, squeeze=nrows * ncols == 1)
    return fig, ax


def save_figure(fig, path: str | os.PathLike) -> None:
    """Save a PNG atomically and free the figure."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    try:
        with atomic_write(path, binary=True) as f:
            fig.savefig(f, format="png", dpi=150)
    finally:
        plt.close(fig)


# ------------------------------------------------------------------------ trajectories

_ARROW = {(0, 1): "^", (0, -1): "v", (1, 0): ">", (-1, 0): "<", (0, 0): "o"}


def draw_plan(ax, instance: Instance, plan: Plan, title: str = "") -> None:
    """Path with direction markers (red where a sensor uploads), sensors and their ranges."""
    from matplotlib.patches import Circle

    lat = lattice_mod.build(instance)
    ax.scatter(lat.points[:, 0], lat.points[:, 1], s=4, color="0.8", zorder=1)
    for i, s in enumerate(instance.sensors):
        ax.add_patch(Circle(s.position, instance.channel.d_th, fill=False, ls=":", color="tab:red", alpha=0.5))
        ax.scatter(*s.position, marker="x", s=60, color="tab:red", zorder=4)
        ax.annotate(f"s{i} (rho {s.rho:.2f})", s.position, xytext=(4, 4), textcoords="offset points", fontsize=7, color="tab:red")
    pts = np.array(plan.positions)
    ax.plot(pts[:, 0], pts[:, 1], color="tab:blue", lw=1.2, alpha=0.7, zorder=2)
    ax.scatter(*pts[0], marker="s", s=70, facecolor="none", edgecolor="black", zorder=5, label="start")
    step = instance.step
    for t, (x, y) in enumerate(plan.positions):
        nxt = plan.positions[t + 1] if t + 1 < len(plan.positions) else (x, y)
        move = (round((nxt[0] - x) / step), round((nxt[1] - y) / step))
        u = plan.schedule[t]
        ax.scatter(x, y, marker=_ARROW.get(move, "o"), s=45, color="tab:red" if u is not None else "tab:blue", zorder=3)
        if u is not None:
            ax.annotate(f"t{t}:s{u}", (x, y), xytext=(-6, -11), textcoords="offset points", fontsize=6)
    ax.set_xlim(-0.4, instance.width + 0.4)
    ax.set_ylim(-0.4, instance.height + 0.4)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)


def plot_result(result: Result, instance: Instance, path: str | os.PathLike) -> None:
    """``voiopt plot``: one result's trajectory, with its simulated metrics in the title."""
    if result.plan is None:
        raise OptionError(f"RESULT: the result has no plan (status {result.status})")
    metrics = simulate(instance, result.plan).metrics  # re-simulated: the file is not trusted
    fig, ax = start_figure(figsize=(5.2, 5.2))
    title = f"{instance.name} — {result.method}, {result.objective} = {metrics[result.objective]:.4g} ({result.status})"
    draw_plan(ax, instance, result.plan, title)
    save_figure(fig, path)


# ------------------------------------------------------------------------ sweeps

@dataclass(frozen=True)
class Sweep:
    key: str  # file stem
    title: str
    x_label: str
    values: tuple[float, ...]
    log_x: bool = False

    def generator_kwargs(self, v: float) -> dict[str, Any]:
        base = dict(n_sensors=4, horizon=30, rho=(0.0, 1.0), power_w=1.0)
        if self.key == "fig5_power":
            base["power_w"] = v
        elif self.key == "fig6_heterogeneity":
            base["rho"] = (0.5 - v, 0.5 + v)
        else:
            base["n_sensors"] = int(v)
        return base


SWEEPS = (
    Sweep("fig5_power", "time-average min VoI vs transmit power (N = 4, rho ~ U(0, 1), T = 30)", "transmit power P (W)", (1e-4, 1e-3, 1e-2, 1e-1, 1.0), log_x=True),
    Sweep("fig6_heterogeneity", "time-average min VoI vs heterogeneity (rho ~ U(0.5 - drho, 0.5 + drho), N = 4, P = 1 W, T = 30)", "drho", (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)),
    Sweep("fig7_nodes", "time-average min VoI vs number of nodes (rho ~ U(0, 1), P = 1 W, T = 30)", "number of nodes N", (2, 3, 4, 5, 6, 7, 8)),
)


def _sweep_instances(sweep: Sweep, networks: int, seed: int, out: Path) -> dict[float, list[Path]]:
    """The networks of each sweep value, written once.

    Every value uses the same seed (common random numbers): along the power and drho sweeps
    network k keeps its positions, start and uniform draws, and only the swept parameter
    changes, so the curves show the parameter's effect rather than network-to-network noise."""
    paths = {}
    for v in sweep.values:
        folder = out / "instances" / sweep.key / f"{v:g}"
        insts = generate_set(networks, seed=seed, name=f"{sweep.key}-{v:g}-seed{seed}", **sweep.generator_kwargs(v))
        paths[v] = write_set(insts, folder)
    return paths


def _aggregate(sweep: Sweep, results: dict[tuple[float, str], list[tuple[int | None, Result]]]) -> list[dict[str, Any]]:
    """Per sweep value and method: the mean over networks for each seed, then the mean over
    seeds with their min and max (a deterministic method has one 'seed')."""
    rows = []
    for v in sweep.values:
        for m in SCHEMES:
            runs = results[(v, m)]
            by_seed: dict[int | None, list[float]] = {}
            for seed, r in runs:
                if r.value is not None:
                    by_seed.setdefault(seed, []).append(r.value)
            seed_means = [statistics.fmean(vals) for vals in by_seed.values()]
            per_network = [r.value for _, r in runs if r.value is not None]
            sd = statistics.stdev(per_network) if len(per_network) > 1 else 0.0
            bounds = [r.bound if r.bound is not None else math.nan for _, r in runs]
            n_networks = len({r.instance for _, r in runs})
            rows.append({
                "x": v, "method": m, "networks": n_networks, "seeds": len(by_seed) if m in RANDOMISED else "",
                "mean": statistics.fmean(seed_means) if seed_means else None,
                "seed_min": min(seed_means) if seed_means else None,
                "seed_max": max(seed_means) if seed_means else None,
                "ci95": 1.96 * sd / math.sqrt(len(per_network)) if per_network else None,
                "mean_bound": statistics.fmean(bounds) if m == "dp" and bounds and not any(map(math.isnan, bounds)) else None,
                "certified": sum(r.status == "optimal" for _, r in runs) if m == "dp" else None,
                "errors": sum(r.status == "error" for _, r in runs),
            })
    return rows


def _plot_sweep(sweep: Sweep, rows: list[dict[str, Any]], path: Path) -> None:
    fig, ax = start_figure(figsize=(6.0, 4.2))
    for m, label in SCHEMES.items():
        mine = [r for r in rows if r["method"] == m and r["mean"] is not None]
        xs = [r["x"] for r in mine]
        ys = [r["mean"] for r in mine]
        ax.plot(xs, ys, label=label, color=COLOURS[m], marker="o", ms=4, ls="--" if m == "dp" else "-")
        if m in RANDOMISED:
            ax.fill_between(xs, [r["seed_min"] for r in mine], [r["seed_max"] for r in mine],
                            color=COLOURS[m], alpha=0.2, lw=0)
        if m == "dp":
            uncertified = [r for r in mine if r["certified"] is not None and r["certified"] < r["networks"] and r["mean_bound"] is not None]
            if uncertified:
                ax.fill_between([r["x"] for r in mine], ys, [r["mean_bound"] or r["mean"] for r in mine],
                                color="0.6", alpha=0.3, label="proven upper bound (not certified)")
    if sweep.log_x:
        ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(sweep.x_label)
    ax.set_ylabel("time-average minimum VoI (bit/s)\nmean over networks; Q-learning: mean over seeds,\nband from the worst to the best seed", fontsize=8)
    ax.set_title(sweep.title, fontsize=8)
    ax.legend(fontsize=7)
    save_figure(fig, path)


# ------------------------------------------------------------------------ the whole set

def make_figures(
    out_dir: str | os.PathLike,
    *,
    networks: int = 40,
    episodes: int | None = None,
    time_limit: float = 60.0,
    seed: int = 0,
    seeds: int = 3,
    reward_units: str = "bit/s",
    workers: int = 1,
    dask_scheduler: str | None = None,
    progress: bool = False,
    case_study_instance: Instance | None = None,
) -> list[Path]:
    """Reproduce Figs. 3-7 with the proven optimum; return the files written."""
    from voiopt.report import (
        check_manifest,
        check_seeds,
        method_tasks,
        read_csv,
        run_tasks,
        write_csv,
    )

    if networks < 1:
        raise OptionError(f"--networks: must be >= 1, got {networks}")
    check_seeds(seeds)
    check_reward_units(reward_units)
    out = Path(out_dir)
    opts = dict(time_limit=time_limit, episodes=episodes, reward_units=reward_units, threads=1)
    check_manifest(out, {"command": "figures", "networks": networks, "seed": seed, "seeds": seeds, **opts})

    # the case study (Figs. 3 and 4): the plans drawn are those of the first seed
    inst = case_study_instance or case_study()
    cs_path = out / "instances" / f"{inst.name}.json"
    instance_mod.save(inst, cs_path)
    cs_tasks = method_tasks(cs_path, inst.name, list(SCHEMES), OBJECTIVE, out / "results" / "case-study",
                            seed, seeds, **opts)
    tasks = list(cs_tasks)
    sweep_tasks: dict[str, tuple[Sweep, dict[float, list[Path]], list]] = {}
    for sweep in SWEEPS:
        inst_paths = _sweep_instances(sweep, networks, seed, out)
        ts = [t for v in sweep.values for p in inst_paths[v]
              for t in method_tasks(p, p.stem, list(SCHEMES), OBJECTIVE, out / "results" / sweep.key, seed, seeds, **opts)]
        sweep_tasks[sweep.key] = (sweep, inst_paths, ts)
        tasks += ts
    run_tasks(tasks, workers=workers, dask_scheduler=dask_scheduler, progress=progress, description="figure runs")

    written = []
    cs_results = {t.method: load_result(t.out_path) for t in cs_tasks if t.seed in (None, seed)}
    cs_seed_values = {m: [load_result(t.out_path).value for t in cs_tasks if t.method == m] for m in SCHEMES}
    written += _case_study_figures(inst, cs_results, out)
    md = ["# The paper's figures, with the proven optimum", ""]
    md += [f"Networks per setting: {networks}; Q-learning episodes: {episodes or 'paper default (1e6)'}, "
           f"seeds {seed}..{seed + seeds - 1}, reward in {reward_units} with idle penalty 100 (MODEL.md section 7); "
           f"exact method: dp with a {time_limit:g} s limit per network. "
           "Values are means over networks of the simulated time-average minimum VoI; for Q-learning the mean "
           "over seeds, with a band from the worst to the best seed's mean.", ""]
    md += ["## Fig. 3 and 4: case study", "", "![fig3](fig3_case_study.png)", "", "![fig4](fig4_voi_over_time.png)", ""]
    md += [f"Plans drawn: seed {seed}. mean-min-voi over seeds: "
           + "; ".join(f"{SCHEMES[m]} {_spread(vals)}" for m, vals in cs_seed_values.items()), ""]
    md += ["| scheme | status | mean-min-voi | min-voi | max-aoi | mean-max-aoi |", "|---|---|---:|---:|---:|---:|"]
    for m, r in cs_results.items():
        mt = r.metrics or {}
        md.append(f"| {SCHEMES[m]} | {r.status} | " + " | ".join(f"{mt.get(k, float('nan')):.6g}" for k in ("mean-min-voi", "min-voi", "max-aoi", "mean-max-aoi")) + " |")
    for key, (sweep, inst_paths, ts) in sweep_tasks.items():
        results: dict[tuple[float, str], list[tuple[int | None, Result]]] = {}
        for v in sweep.values:
            stems = {p.stem for p in inst_paths[v]}
            for m in SCHEMES:
                results[(v, m)] = [(t.seed, load_result(t.out_path)) for t in ts if t.method == m and t.instance_name in stems]
        rows = _aggregate(sweep, results)
        csv_path = out / f"{key}.csv"
        header = [sweep.title, f"x = {sweep.x_label}; sweep values {list(sweep.values)}; {networks} networks each; "
                  f"seeds {seed}..{seed + seeds - 1}; Q-learning reward in {reward_units}",
                  "mean: of the simulated mean-min-voi (bit/s) over networks, then over seeds; seed_min/seed_max: the worst and best seed's mean; "
                  "ci95: over networks; dp rows: certified = networks proven optimal, mean_bound = mean proven upper bound"]
        write_csv(csv_path, rows, ["x", "method", "networks", "seeds", "mean", "seed_min", "seed_max", "ci95",
                                   "mean_bound", "certified", "errors"], header)
        _plot_sweep(sweep, rows, out / f"{key}.png")
        written += [out / f"{key}.png", csv_path]
        md += ["", f"## {key}", "", f"![{key}]({key}.png)", "", f"{sweep.title}. Numbers: `{key}.csv`.", "",
               "| x | " + " | ".join(SCHEMES.values()) + " | dp certified |", "|---|" + "---:|" * (len(SCHEMES) + 1)]
        for v in sweep.values:
            cells = {r["method"]: r for r in read_csv(csv_path) if float(r["x"]) == v}
            md.append(f"| {v:g} | " + " | ".join(f"{float(cells[m]['mean']):.4g}" if cells[m]["mean"] else "-" for m in SCHEMES)
                      + f" | {cells['dp']['certified']}/{cells['dp']['networks']} |")
    md_path = out / "figures.md"
    with atomic_write(md_path) as f:
        f.write("\n".join(md) + "\n")
    return [*written, md_path]


def _spread(values: list[float | None]) -> str:
    vals = [v for v in values if v is not None]
    if not vals:
        return "-"
    if len(vals) == 1:
        return f"{vals[0]:.4g}"
    return f"mean {statistics.fmean(vals):.4g} (min {min(vals):.4g}, max {max(vals):.4g})"


def _case_study_figures(inst: Instance, results: dict[str, Result], out: Path) -> list[Path]:
    from voiopt.report import write_csv

    fig, axes = start_figure(2, 2, figsize=(10, 10))
    for ax, (m, r) in zip(axes.ravel(), results.items(), strict=True):
        if r.plan is None:
            ax.set_title(f"{SCHEMES[m]}: no plan ({r.status})")
            continue
        metric = simulate(inst, r.plan).metrics[OBJECTIVE]
        draw_plan(ax, inst, r.plan, f"{SCHEMES[m]}: mean-min-voi {metric:.4g}")
    save_figure(fig, out / "fig3_case_study.png")

    fig, ax = start_figure(figsize=(6, 4))
    rows = []
    for m, r in results.items():
        if r.plan is None:
            continue
        traj = simulate(inst, r.plan)
        avg = traj.voi[1:].mean(axis=1)
        ax.plot(range(1, inst.horizon + 1), avg, marker="o", ms=3, label=SCHEMES[m], color=COLOURS[m])
        rows += [{"t": t + 1, "method": m, "average_voi": a, "min_voi": float(traj.voi[t + 1].min())} for t, a in enumerate(avg)]
    ax.set_yscale("log")
    ax.set_xlabel("time slot t")
    ax.set_ylabel("average VoI over sensors (bit/s)")
    ax.set_title(f"{inst.name}: average VoI over time", fontsize=9)
    ax.legend(fontsize=7)
    save_figure(fig, out / "fig4_voi_over_time.png")
    write_csv(out / "fig4_voi_over_time.csv", rows, ["t", "method", "average_voi", "min_voi"],
              [f"{inst.name}: per-slot average and minimum VoI over sensors (bit/s), simulated from each scheme's plan"])
    write_csv(out / "fig3_case_study.csv",
              [{"method": m, "slot": t, "x": p[0], "y": p[1], "upload": r.plan.schedule[t]}
               for m, r in results.items() if r.plan is not None for t, p in enumerate(r.plan.positions)],
              ["method", "slot", "x", "y", "upload"], [f"{inst.name}: each scheme's plan, position and uploaded sensor per slot"])
    return [out / "fig3_case_study.png", out / "fig3_case_study.csv", out / "fig4_voi_over_time.png", out / "fig4_voi_over_time.csv"]


def load_instance_for(result: Result, instance_path: str | None) -> Instance:
    """The instance a result belongs to: given, or instances/NAME.json, or the built-in case study."""
    if instance_path:
        inst = instance_mod.load(instance_path)
    elif Path("instances", f"{result.instance}.json").is_file():
        inst = instance_mod.load(Path("instances", f"{result.instance}.json"))
    elif result.instance == "case-study":
        inst = case_study()
    else:
        raise OptionError(f"--instance: give the instance of result {result.instance!r} (not found as instances/{result.instance}.json)")
    if inst.name != result.instance:
        raise OptionError(f"--instance: the result is for {result.instance!r}, the instance is {inst.name!r}")
    return inst


