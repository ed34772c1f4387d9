"""The paper's figures with the proven optimum added (MODEL.md section 8).

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

from voiopt.core import instance as instance_mod
from voiopt.core.instance import Instance
from voiopt.core.result import Result, load_result
from voiopt.experiments.plots import SCHEMES, case_study_figures, plot_sweep
from voiopt.experiments.runner import (
    check_manifest,
    count_option,
    freed_unless_stored,
    method_tasks,
    run_options,
    run_tasks,
)
from voiopt.networks.generate import case_study, generate_set, write_set
from voiopt.objectives import DEFAULT as OBJECTIVE
from voiopt.objectives import OBJECTIVES
from voiopt.runtime.files import atomic_write, check_output_dir, read_csv, safe_name, write_csv
from voiopt.runtime.status import Status
from voiopt.solvers import RANDOMISED
from voiopt.solvers.base import DEFAULT_MEMORY_GB


@dataclass(frozen=True)
class Sweep:
    key: str  # file stem
    title: str
    x_label: str
    values: tuple[float, ...]
    log_x: bool = False

    def generator_kwargs(self, v: float) -> dict[str, Any]:
        base = dict(n_sensors=4, horizon=30, rho=(0.0, 1.0), power_w=1.0)
        if self.key == "fig8_robots":
            base.update(n_sensors=8, robots=int(v))
        elif self.key == "fig5_power":
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


def _sweep_instances(sweep: Sweep, networks: int, seed: int, out: Path) -> dict[float, list[tuple[Path, Instance]]]:
    """The networks of each sweep value, written once (for the record; the runs take them from
    memory).

    Every value uses the same seed (common random numbers): along the power and drho sweeps
    network k keeps its positions, start and uniform draws, and only the swept parameter
    changes, so the curves show the parameter's effect rather than network-to-network noise."""
    paths = {}
    for v in sweep.values:
        folder = out / "instances" / sweep.key / f"{v:g}"
        insts = generate_set(networks, seed=seed, name=f"{sweep.key}-{v:g}-seed{seed}", **sweep.generator_kwargs(v))
        paths[v] = list(zip(write_set(insts, folder), insts, strict=True))
    return paths


def _aggregate(sweep: Sweep, results: dict[tuple[float, str], list[tuple[int | None, Result]]]) -> list[dict[str, Any]]:
    """Per sweep value and method: the mean over networks for each seed, then the mean over
    seeds with their min and max (a deterministic method has one 'seed')."""
    rows = []
    for v in sweep.values:
        for m in SCHEMES:
            runs = results[(v, m)]
            by_seed = _values_by_seed(runs)
            seed_means = [statistics.fmean(vals) for vals in by_seed.values()]
            per_network = _network_means(runs)  # a randomised method's seeds averaged first: the CI is over networks
            bounds = [r.bound if r.bound is not None else math.nan for _, r in runs]
            n_networks = len({r.instance for _, r in runs})
            rows.append({
                "x": v, "method": m, "networks": n_networks, "seeds": len(by_seed) if m in RANDOMISED else "",
                "mean": statistics.fmean(seed_means) if seed_means else None,
                "seed_min": min(seed_means) if seed_means else None,
                "seed_max": max(seed_means) if seed_means else None,
                "ci95": ci95(per_network),
                "mean_bound": statistics.fmean(bounds) if m == "dp" and bounds and not any(map(math.isnan, bounds)) else None,
                "certified": sum(r.status == Status.OPTIMAL for _, r in runs) if m == "dp" else None,
                "errors": sum(r.status == Status.ERROR for _, r in runs),
            })
    return rows


def _network_means(runs) -> list[float]:
    """Per network, the mean simulated value over its (seed, Result) runs with a plan."""
    by_network: dict[str, list[float]] = {}
    for _, r in runs:
        if r.value is not None:
            by_network.setdefault(r.instance, []).append(r.value)
    return [statistics.fmean(v) for v in by_network.values()]


def _values_by_seed(runs) -> dict[int | None, list[float]]:
    """The simulated values of (seed, Result) runs with a plan, per seed (None: deterministic)."""
    by_seed: dict[int | None, list[float]] = {}
    for seed, r in runs:
        if r.value is not None:
            by_seed.setdefault(seed, []).append(r.value)
    return by_seed


def ci95(values: list[float]) -> float | None:
    """The half-width of the 95 % confidence interval of the mean of ``values`` (the networks'
    means), with Student's t for n - 1 degrees of freedom: the networks are few (5 in
    docs/reproduce.md), and the normal quantile 1.96 used until 2026-12-03 made the interval
    1.4 times too narrow at 5 networks and 6.5 times at 2. None from one value."""
    if len(values) < 2:
        return None
    from scipy.stats import t

    return float(t.ppf(0.975, len(values) - 1)) * statistics.stdev(values) / math.sqrt(len(values))


# --time-limit is dp's: the paper's Q-learning always runs its episodes (a wall-clock limit
# would make the curves depend on the machine's load)
EXACT_ONLY = {"time_limit": ["dp"]}

# Fig. 8 (not in the paper): several robots (MODEL.md section 10) at N = 8, T = 30. The
# optimum is the best of the two exact methods per network: dp (which plans jointly for two
# robots where the product state fits, and declines otherwise) and milp; both get --time-limit.
ROBOTS = Sweep("fig8_robots", "time-average min VoI vs number of robots (N = 8, rho ~ U(0, 1), P = 1 W, T = 30)",
               "number of robots K", (1, 2, 3))
ROBOT_METHODS = ("dp", "milp", "qlearning", "aoi-qlearning", "shortest-path", "greedy")
ROBOT_EXACT = {"time_limit": ["dp", "milp"]}


def make_figures(
    out_dir: str | os.PathLike,
    *,
    networks: int = 40,
    robot_networks: int = 10,
    episodes: int | None = None,
    time_limit: float = 60.0,
    memory_limit: float = DEFAULT_MEMORY_GB,
    seed: int = 0,
    seeds: int = 3,
    reward_units: str = "bit/s",
    progress: bool = False,
    workers: int = 1,
    dask_scheduler: str | None = None,
    case_study_instance: Instance | None = None,
) -> list[Path]:
    """Reproduce Figs. 3-7 with the proven optimum, and Fig. 8 (several robots, ``robot_networks``
    networks per number of robots); return the files written."""
    count_option(networks, "--networks")
    count_option(robot_networks, "--robot-networks")
    opts = run_options(time_limit=time_limit, memory_limit=memory_limit, episodes=episodes,
                       reward_units=reward_units, seeds=seeds, workers=workers, dask_scheduler=dask_scheduler,
                       seed=seed)
    out = check_output_dir(out_dir, "--out")
    created = check_manifest(out, {"command": "figures", "networks": networks, "robot_networks": robot_networks, "seed": seed,
                         "seeds": seeds, **opts}, "--out")

    # the case study (Figs. 3 and 4): the plans drawn are those of the first seed
    inst = case_study_instance or case_study()
    cs_path = out / "instances" / f"{safe_name(inst.name)}.json"
    instance_mod.save(inst, cs_path)
    cs_tasks = method_tasks(inst, cs_path, list(SCHEMES), OBJECTIVE, out / "results" / "case-study",
                            seed, seeds, group="case study", only=EXACT_ONLY, **opts)
    tasks = list(cs_tasks)
    sweep_tasks: dict[str, tuple[Sweep, dict[float, list[tuple[Path, Instance]]], list]] = {}
    for sweep in SWEEPS:
        insts = _sweep_instances(sweep, networks, seed, out)
        ts = [t for v in sweep.values for p, i in insts[v]
              for t in method_tasks(i, p, list(SCHEMES), OBJECTIVE, out / "results" / sweep.key, seed, seeds,
                                    group=f"{sweep.key} {sweep.x_label} = {v:g}", only=EXACT_ONLY, **opts)]
        sweep_tasks[sweep.key] = (sweep, insts, ts)
        tasks += ts
    robot_insts = _sweep_instances(ROBOTS, robot_networks, seed, out)
    robot_tasks = [t for v in ROBOTS.values for p, i in robot_insts[v]
                   for t in method_tasks(i, p, list(ROBOT_METHODS), OBJECTIVE, out / "results" / ROBOTS.key, seed,
                                         seeds, group=f"{ROBOTS.key} K = {v:g}", only=ROBOT_EXACT, **opts)]
    tasks += robot_tasks
    with freed_unless_stored(out, created):
        run_tasks(tasks, workers=workers, dask_scheduler=dask_scheduler, progress=progress, description="figure runs")

    written = []
    cs_results = {t.method: load_result(t.out_path) for t in cs_tasks if t.seed in (None, seed)}
    cs_seed_values = {m: [load_result(t.out_path).value for t in cs_tasks if t.method == m] for m in SCHEMES}
    written += case_study_figures(inst, cs_results, out)
    md = ["# The paper's figures, with the proven optimum", ""]
    md += [f"Networks per setting: {networks}; Q-learning episodes: {episodes or 'paper default (1e6)'}, "
           f"seeds {seed}..{seed + seeds - 1}, reward in {reward_units} with idle penalty 100 (MODEL.md section 7); "
           f"exact method: dp with a {time_limit:g} s limit per network. "
           "Values are means over networks of the simulated time-average minimum VoI; for Q-learning the mean "
           "over seeds, with a band from the worst to the best seed's mean.", ""]
    md += ["## Fig. 3 and 4: case study", "", "![fig3](fig3_case_study.png)", "", "![fig4](fig4_voi_over_time.png)", ""]
    md += [f"Plans drawn: seed {seed}. mean-min-voi over seeds: "
           + "; ".join(f"{SCHEMES[m]} {_spread(vals)}" for m, vals in cs_seed_values.items()), ""]
    md += ["| scheme | status | " + " | ".join(OBJECTIVES) + " |", "|---|---|" + "---:|" * len(OBJECTIVES)]
    for m, r in cs_results.items():
        mt = r.metrics or {}
        md.append(f"| {SCHEMES[m]} | {r.status} | " + " | ".join(f"{mt.get(k, float('nan')):.6g}" for k in OBJECTIVES) + " |")
    for key, (sweep, insts, ts) in sweep_tasks.items():
        results: dict[tuple[float, str], list[tuple[int | None, Result]]] = {}
        for v in sweep.values:
            stems = {i.name for _, i in insts[v]}
            for m in SCHEMES:
                results[(v, m)] = [(t.seed, load_result(t.out_path)) for t in ts if t.method == m and t.instance_name in stems]
        rows = _aggregate(sweep, results)
        csv_path = out / f"{key}.csv"
        header = [sweep.title, f"x = {sweep.x_label}; sweep values {list(sweep.values)}; {networks} networks each; "
                  f"seeds {seed}..{seed + seeds - 1}; Q-learning reward in {reward_units}",
                  "mean: of the simulated mean-min-voi (bit/s) over networks, then over seeds; seed_min/seed_max: the worst and best seed's mean; "
                  "ci95: half-width of the 95 % interval over networks (Student's t; each network's mean over the seeds); dp rows: certified = networks proven optimal, mean_bound = mean proven upper bound"]
        write_csv(csv_path, rows, ["x", "method", "networks", "seeds", "mean", "seed_min", "seed_max", "ci95",
                                   "mean_bound", "certified", "errors"], header)
        plot_sweep(sweep, rows, out / f"{key}.png")
        written += [out / f"{key}.png", csv_path]
        md += ["", f"## {key}", "", f"![{key}]({key}.png)", "", f"{sweep.title}. Numbers: `{key}.csv`.", "",
               "| x | " + " | ".join(SCHEMES.values()) + " | dp certified |", "|---|" + "---:|" * (len(SCHEMES) + 1)]
        for v in sweep.values:
            cells = {r["method"]: r for r in read_csv(csv_path) if float(r["x"]) == v}
            md.append(f"| {v:g} | " + " | ".join(f"{float(cells[m]['mean']):.4g}" if cells[m]["mean"] else "-" for m in SCHEMES)
                      + f" | {cells['dp']['certified']}/{cells['dp']['networks']} |")
    written += _robots_figure(robot_insts, robot_tasks, robot_networks, seed, seeds, reward_units, time_limit, out, md)
    md_path = out / "figures.md"
    with atomic_write(md_path) as f:
        f.write("\n".join(md) + "\n")
    return [*written, md_path]


def _robots_figure(insts, tasks, networks: int, seed: int, seeds: int, reward_units: str, time_limit: float,
                   out: Path, md: list[str]) -> list[Path]:
    """Fig. 8: each method and the certified optimum against the number of robots. Per network
    the optimum's value is the best exact plan and its bound the tightest proven bound of dp
    and milp; a network is certified when they meet (relative 1e-6)."""
    from voiopt.experiments.plots import plot_robots
    from voiopt.objectives import gap

    rows = []
    for v in ROBOTS.values:
        stems = {i.name for _, i in insts[v]}
        mine = [t for t in tasks if t.instance_name in stems]
        results = {m: [(t.seed, load_result(t.out_path), t.instance_name) for t in mine if t.method == m]
                   for m in ROBOT_METHODS}
        best: dict[str, tuple[float | None, float | None]] = {}
        for name in sorted(stems):
            exact = [r for m in ("dp", "milp") for _, r, n in results[m] if n == name]
            values = [r.value for r in exact if r.value is not None]
            bounds = [r.bound for r in exact if r.bound is not None]
            best[name] = (max(values) if values else None, min(bounds) if bounds else None)
        values = [b[0] for b in best.values() if b[0] is not None]
        bounds = [b[1] for b in best.values() if b[1] is not None]
        certified = sum(b[0] is not None and b[1] is not None and gap(b[0], b[1]) <= 1e-6 for b in best.values())
        rows.append({"x": v, "method": "optimum", "networks": len(stems), "seeds": "",
                     "mean": statistics.fmean(values) if len(values) == len(stems) else None,
                     "seed_min": None, "seed_max": None, "ci95": None,
                     "mean_bound": statistics.fmean(bounds) if len(bounds) == len(stems) else None,
                     "certified": certified, "errors": ""})
        for m in ROBOT_METHODS:
            runs = results[m]
            by_seed = _values_by_seed((s, r) for s, r, _ in runs)
            seed_means = [statistics.fmean(x) for x in by_seed.values() if len(x) == len(stems)]
            rows.append({"x": v, "method": m, "networks": len(stems), "seeds": len(by_seed) if m in RANDOMISED else "",
                         "mean": statistics.fmean(seed_means) if seed_means else None,
                         "seed_min": min(seed_means) if seed_means else None,
                         "seed_max": max(seed_means) if seed_means else None, "ci95": None,
                         "mean_bound": None, "certified": sum(r.status == Status.OPTIMAL for _, r, _ in runs),
                         "errors": sum(r.status == Status.ERROR for _, r, _ in runs)})
    key = ROBOTS.key
    csv_path = out / f"{key}.csv"
    write_csv(csv_path, rows, ["x", "method", "networks", "seeds", "mean", "seed_min", "seed_max", "ci95",
                               "mean_bound", "certified", "errors"],
              [ROBOTS.title, f"x = {ROBOTS.x_label}; {networks} networks each (robot 0 is the one-robot network's, "
                             f"the others at distinct random starts); seeds {seed}..{seed + seeds - 1}; "
                             f"Q-learning reward in {reward_units}",
               "optimum rows: mean of the best exact plan and of the tightest proven bound (dp, milp, "
               f"{time_limit:g} s each), certified = networks where they meet; a method's mean is empty where "
               "it declined or failed on some network (errors counts those runs)"])
    plot_robots(ROBOTS, rows, out / f"{key}.png")
    md += ["", f"## {key} (several robots, not in the paper)", "", f"![{key}]({key}.png)", "",
           f"{ROBOTS.title}. Numbers: `{key}.csv`.", "",
           "| K | best exact plan (networks certified optimal) | proven bound | " + " | ".join(ROBOT_METHODS) + " |",
           "|---|---:|---:|" + "---:|" * len(ROBOT_METHODS)]
    fmt = lambda x: "-" if x in (None, "") else f"{float(x):.4g}"  # noqa: E731
    for v in ROBOTS.values:
        cells = {r["method"]: r for r in rows if r["x"] == v}
        opt = cells["optimum"]
        md.append(f"| {v:g} | {fmt(opt['mean'])} ({opt['certified']}/{opt['networks']}) | {fmt(opt['mean_bound'])} | "
                  + " | ".join(fmt(cells[m]["mean"]) for m in ROBOT_METHODS) + " |")
    return [out / f"{key}.png", csv_path]


def _spread(values: list[float | None]) -> str:
    vals = [v for v in values if v is not None]
    if not vals:
        return "-"
    if len(vals) == 1:
        return f"{vals[0]:.4g}"
    return f"mean {statistics.fmean(vals):.4g} (min {min(vals):.4g}, max {max(vals):.4g})"
