"""Plots (matplotlib, Agg): plan drawings, the gap distributions of a report, the paper's
sweeps and case-study figures. Every value drawn is simulated from a plan."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from voiopt.core import instance as instance_mod
from voiopt.core.expectation import expected_metrics
from voiopt.core.instance import Instance
from voiopt.core.links import is_lossy
from voiopt.core.plan import FleetPlan, Plan
from voiopt.core.result import Result, disagreement
from voiopt.core.simulate import simulate
from voiopt.errors import OptionError
from voiopt.grid import lattice as lattice_mod
from voiopt.networks.generate import case_study
from voiopt.objectives import DEFAULT as OBJECTIVE
from voiopt.runtime.files import atomic_write, write_csv
from voiopt.solvers import RANDOMISED

SCHEMES = {  # method -> label in the paper's words
    "qlearning": "VoI-optimal (Q-learning)",
    "aoi-qlearning": "AoI-optimal (Q-learning)",
    "shortest-path": "shortest path",
    "dp": "dp (the optimum where certified)",
}

COLOURS = {"qlearning": "tab:blue", "aoi-qlearning": "tab:orange", "shortest-path": "tab:green", "dp": "black"}


def start_figure(nrows: int = 1, ncols: int = 1, figsize=(5.0, 4.0)):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(nrows, ncols, figsize=figsize, squeeze=nrows * ncols == 1)
    return fig, ax


FIGURE_FORMATS = (".png", ".pdf", ".svg")


def check_figure_path(path: str | os.PathLike) -> str:
    """The matplotlib format of a figure file, from its suffix; any other suffix is an error."""
    suffix = Path(path).suffix.lower()
    if suffix not in FIGURE_FORMATS:
        raise OptionError(f"-o/--output: {str(path)!r}: a figure is written as .png, .pdf or .svg, got {suffix or 'no suffix'!r}")
    return suffix[1:]


def save_figure(fig, path: str | os.PathLike) -> None:
    """Save a figure atomically in the format its suffix names, and free it."""
    import matplotlib.pyplot as plt

    fmt = check_figure_path(path)
    fig.tight_layout()
    try:
        with atomic_write(path, binary=True) as f:
            fig.savefig(f, format=fmt, dpi=150)
    finally:
        plt.close(fig)


_ARROW = {(0, 1): "^", (0, -1): "v", (1, 0): ">", (-1, 0): "<", (0, 0): "o"}


ROBOT_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan")


RANGES_PER_LINE = 3  # slot ranges on one line of an upload label before it goes on to the next


def upload_labels(plan: Plan) -> dict[tuple[float, float], str]:
    """One label per point where a robot uploads, so that labels never cover each other: one
    line per sensor uploaded there, in the order of its first upload, naming its slots as
    ranges (t1-3,7,10-12:s0), at most RANGES_PER_LINE ranges a line (the rest on the next).
    A robot that waits at a sensor for most of a long horizon gets a line or two, not one a
    visit (until 2026-12-03 every run of slots had its own line, and tall labels covered the
    next point's)."""
    runs: dict[tuple[float, float], dict[int, list[list[int]]]] = {}
    for t, (point, u) in enumerate(zip(plan.positions, plan.schedule, strict=True)):
        if u is None:
            continue
        at = runs.setdefault(point, {}).setdefault(u, [])
        if at and at[-1][1] == t - 1:
            at[-1][1] = t
        else:
            at.append([t, t])
    labels = {}
    for point, by_sensor in runs.items():
        lines = []
        for u, slots in by_sensor.items():
            ranges = [f"{a}" if a == b else f"{a}-{b}" for a, b in slots]
            lines += [f"t{','.join(ranges[i: i + RANGES_PER_LINE])}:s{u}" for i in range(0, len(ranges), RANGES_PER_LINE)]
        labels[point] = "\n".join(lines)
    return labels


_BOX = {"boxstyle": "round,pad=0.1", "facecolor": "white", "alpha": 0.75, "edgecolor": "none"}  # text over lines stays legible
SENSOR = "0.2"  # sensors, their names and ranges: red is the uploads' colour (and the viewer's failed upload, a red x)
SENSOR_MARKER, SENSOR_SIZE = "h", 70  # a filled hexagon: squares are starts, triangles moves, diamonds docks
PATH_SIZE = 45
# where a label may go beside its point, in offset points (dx, dy, ha, va), in order of preference:
# each clears a marker of its point (a path marker's radius is sqrt(PATH_SIZE) / 2, 3.4 points)
SENSOR_PLACES = ((5, 5, "left", "bottom"), (5, -5, "left", "top"), (-5, 5, "right", "bottom"), (-5, -5, "right", "top"),
                 (7, 0, "left", "center"), (-7, 0, "right", "center"), (0, 7, "center", "bottom"), (0, -7, "center", "top"))
SLOT_PLACES = ((0, -6, "center", "top"), (-5, -5, "right", "top"), (5, -5, "left", "top"), (0, 6, "center", "bottom"),
               (7, 0, "left", "center"), (-7, 0, "right", "center"), (5, 5, "left", "bottom"), (-5, 5, "right", "bottom"))
SLOT_PLACES += tuple((2 * dx, 2 * dy, ha, va) for dx, dy, ha, va in SLOT_PLACES)  # a crowded plot: one step further out


def draw_plan(ax, instance: Instance, plan: Plan | FleetPlan, title: str = "") -> None:
    """Each robot's path in its own colour with direction markers (red where a sensor
    uploads, labelled t{slots}:s{sensor} by ``upload_labels``), its start, sensors (dark
    hexagons) and their ranges. Labels go beside their points where they cover no marker and no
    other label (``place_labels``)."""
    from matplotlib.patches import Circle

    lat = lattice_mod.build(instance)
    ax.scatter(lat.points[~lat.blocked, 0], lat.points[~lat.blocked, 1], s=4, color="0.8", zorder=1)
    markers = _draw_field_rules(ax, instance, plan)
    labels = []
    for i, s in enumerate(instance.sensors):
        ax.add_patch(Circle(s.position, instance.channel.d_th, fill=False, ls=":", color=SENSOR, alpha=0.45))
        ax.scatter(*s.position, marker=SENSOR_MARKER, s=SENSOR_SIZE, color=SENSOR, edgecolor="white", lw=0.8, zorder=4)
        markers.append((*s.position, SENSOR_SIZE))
        labels.append((s.position, f"s{i} (rho {s.rho:.2f})", SENSOR_PLACES,
                       {"fontsize": 7, "color": SENSOR, "zorder": 2.6}))  # over the paths and upload labels
    fleet = len(plan.robots) > 1
    for k, robot in enumerate(plan.robots):
        colour = ROBOT_COLOURS[k % len(ROBOT_COLOURS)]
        # robots that pass the same points are drawn slightly apart (the offset is drawing only)
        shift = (k - (len(plan.robots) - 1) / 2) * 0.09 * instance.step if fleet else 0.0
        robot = Plan(tuple((x + shift, y + shift) for x, y in robot.positions), robot.schedule)
        pts = np.array(robot.positions)
        ax.plot(pts[:, 0], pts[:, 1], color=colour, lw=1.2, alpha=0.7, zorder=2, label=f"robot {k}" if fleet else None)
        ax.scatter(*pts[0], marker="s", s=70, facecolor="none", edgecolor="black" if not fleet else colour, zorder=5,
                   label="start" if k == 0 and not fleet else None)
        markers += [(x, y, PATH_SIZE) for x, y in dict.fromkeys(robot.positions)]
        step = instance.step
        for t, (x, y) in enumerate(robot.positions):
            nxt = robot.positions[t + 1] if t + 1 < len(robot.positions) else (x, y)
            move = (round((nxt[0] - x) / step), round((nxt[1] - y) / step))
            u = robot.schedule[t]
            ax.scatter(x, y, marker=_ARROW.get(move, "o"), s=PATH_SIZE, color="tab:red" if u is not None else colour,
                       edgecolor=colour if fleet else None, linewidths=1.2 if fleet else None, zorder=3)
        labels += [(point, label, SLOT_PLACES, {"fontsize": 6, "color": colour if fleet else "black", "zorder": 2.5})
                   for point, label in upload_labels(robot).items()]
    ax.set_xlim(-0.4, instance.width + 0.4)
    ax.set_ylim(-0.4, instance.height + 0.4)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    if fleet or instance.has_field_rules:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=2, fontsize=7, frameon=False)
    place_labels(ax, labels, markers)


def place_labels(ax, labels, markers) -> None:
    """Annotate each of ``labels`` ((point, text, places, text options), in order) at the first
    of its places (offsets from its point) where its box stays inside the axes and covers none
    of ``markers`` ((x, y, size in points^2)) and no label placed before it; where every place
    covers something (or leaves the axes), at the place that covers least (the first of those).
    Measured on the figure as laid out now (tight_layout first, as save_figure lays it out), in
    display units."""
    import math

    from matplotlib.transforms import Bbox

    fig = ax.figure
    fig.tight_layout()
    ax.apply_aspect()
    renderer = fig.canvas.get_renderer()
    px = fig.dpi / 72  # display units a point
    frame = ax.get_window_extent(renderer)
    inside = lambda box: frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 and box.y1 <= frame.y1  # noqa: E731
    taken = []
    for x, y, size in markers:
        (cx, cy), half = ax.transData.transform((x, y)), (math.sqrt(size) / 2 + 0.5) * px
        taken.append(Bbox.from_extents(cx - half, cy - half, cx + half, cy + half))
    for point, text, places, options in labels:
        best = None
        for dx, dy, ha, va in places:
            note = ax.annotate(text, point, xytext=(dx, dy), textcoords="offset points", ha=ha, va=va, bbox=_BOX,
                               **options)
            box = note.get_window_extent(renderer).expanded(1.02, 1.08)
            covered = sum(box.overlaps(b) for b in taken) + (not inside(box))
            if best is None or covered < best[0]:
                if best is not None:
                    best[1].remove()
                best = (covered, note, box)
            else:
                note.remove()
            if covered == 0:
                break
        taken.append(best[2])


def _draw_field_rules(ax, instance: Instance, plan: Plan | FleetPlan) -> list[tuple[float, float, float]]:
    """MODEL.md section 9: blocked points as filled squares, each end point (a dock) marked,
    and each budget with the moves the plan makes in the legend. The docks' markers (x, y,
    size), which labels keep clear of."""
    from matplotlib.patches import Rectangle

    step = instance.step
    for k, (x, y) in enumerate(instance.blocked):
        ax.add_patch(Rectangle((x - step / 2, y - step / 2), step, step, color="0.35", zorder=0,
                               label="blocked" if k == 0 else None))
    fleet = len(plan.robots) > 1
    docks = []
    for k, (robot, spec) in enumerate(zip(plan.robots, instance.robots, strict=False)):
        who = f"robot {k} " if fleet else ""
        colour = ROBOT_COLOURS[k % len(ROBOT_COLOURS)] if fleet else "tab:green"
        if spec.end is not None:
            ax.scatter(*spec.end, marker="D", s=110, facecolor="none", edgecolor=colour, lw=1.6, zorder=5,
                       label=f"{who}end (dock)")
            docks.append((*spec.end, 110))
        if spec.max_moves is not None:
            moves = sum(a != b for a, b in zip(robot.positions, robot.positions[1:], strict=False))
            ax.plot([], [], " ", label=f"{who}moves {moves} of max_moves {spec.max_moves} "
                                       f"({spec.max_moves - moves} left)")
    return docks


def plot_result(result: Result, instance: Instance, path: str | os.PathLike, where: str = "the instance") -> None:
    """``voiopt plot``: one result's trajectory, with its simulated metrics in the title. The
    result's stored metrics and value must be what its plan gives on ``instance`` (found at
    ``where``): else the instance is not the one it was solved on, or the file was edited,
    and its status cannot be put in a title."""
    if result.plan is None:
        policy = "; a policy result: voiopt show draws a sampled run of its policy" if "policy_file" in result.solver else ""
        raise OptionError(f"RESULT: the result has no plan (status {result.status}){policy}")
    metrics = expected_metrics(instance, result.plan)  # re-simulated (exact expectations if lossy): not trusted
    differ = disagreement(result.metrics, metrics) or disagreement({result.objective: result.value}, metrics)
    if differ:
        raise OptionError(f"RESULT: its plan on {where} does not give what the result says ({differ}): give the "
                          "instance it was solved on with --instance (or the file was edited)")
    fig, ax = start_figure(figsize=(5.2, 5.2 + 0.25 * len(instance.robots) * instance.has_field_rules))
    title = f"{instance.name} — {result.method}, {_expected(instance)}{result.objective} = {metrics[result.objective]:.4g} ({result.status}){_may_fail(instance)}"
    draw_plan(ax, instance, result.plan, title)
    save_figure(fig, path)


def _expected(instance: Instance) -> str:
    """How a title names a value: an exact expectation on a lossy instance (MODEL.md section 11)."""
    return "expected " if is_lossy(instance) else ""


def _may_fail(instance: Instance) -> str:
    """A title's second line on a lossy instance: the uploads drawn are the plan's, as scheduled."""
    return "\nuploads as scheduled, each may fail; voiopt show draws a sampled run" if is_lossy(instance) else ""


def plot_plan(instance: Instance, plan: Plan | FleetPlan, path: str | os.PathLike, label: str,
              objective: str = OBJECTIVE) -> None:
    """``voiopt plot`` of a plan file (no result around it): its trajectory, with its simulated
    ``objective`` in the title."""
    value = expected_metrics(instance, plan)[objective]
    fig, ax = start_figure(figsize=(5.2, 5.2 + 0.25 * len(instance.robots) * instance.has_field_rules))
    draw_plan(ax, instance, plan, f"{instance.name} — {label}, {_expected(instance)}{objective} = {value:.4g}{_may_fail(instance)}")
    save_figure(fig, path)


def plot_gaps(rows: Sequence[dict[str, Any]], methods: Sequence[str], path: Path, objective: str,
              about: str = "") -> None:
    """The gap report's figure: each method's proven gaps; ``about`` (networks, episodes, the
    reward's reading) goes under the title, so the figure says what it shows on its own. Where
    some instance is lossy, a Monte Carlo value's gap has its CI's range as an error bar, and the
    statistical gaps (to an information-relaxation bound) are open markers beside each box."""
    fig, ax = start_figure(figsize=(max(4.2, 1.6 + 1.3 * len(methods)), 3.8))
    data = [[100 * r["gap"] for r in rows if r["method"] == m and r["gap"] is not None] for m in methods]
    positions = range(1, len(methods) + 1)
    ax.boxplot([d or [math.nan] for d in data], positions=list(positions), widths=0.5, showfliers=False)
    for x, d in zip(positions, data, strict=True):
        ax.scatter(_jitter(x, len(d)), d, s=10, alpha=0.6, color="tab:blue", zorder=3)
    lossy = any(r.get("evaluation") is not None for r in rows)
    if lossy:
        _mark_lossy_gaps(ax, rows, methods)
    ax.set_xticks(list(positions), methods, rotation=20)
    ax.set_ylabel("gap to the tightest proven bound (%)" if lossy else "proven gap to optimum (%)")
    what = "gaps to the tightest proven bound (open: statistical)" if lossy else "proven gaps to the optimum"
    ax.set_title(f"{objective}: {what}" + (f"\n{about}" if about else ""), fontsize=9)
    save_figure(fig, path)


def _jitter(x: float, n: int) -> list[float]:
    """Where a box's n dots go, spread around x."""
    return [x + 0.12 * ((k * 0.618) % 1 - 0.5) for k in range(n)]


def _mark_lossy_gaps(ax, rows: Sequence[dict[str, Any]], methods: Sequence[str]) -> None:
    """The lossy runs' labels on the gap figure: CI ranges of Monte Carlo gaps (error bars over
    their dots) and statistical gaps (open orange markers right of the box), with a legend."""
    any_mc = False
    for x, m in enumerate(methods, start=1):
        mine = [r for r in rows if r["method"] == m]
        dots = [r for r in mine if r["gap"] is not None]  # as plot_gaps draws them, in order
        mc = [(at, r) for at, r in zip(_jitter(x, len(dots)), dots, strict=True) if r.get("gap_ci_low") is not None]
        if mc:
            ys = [100 * r["gap"] for _, r in mc]
            err = [[y - 100 * r["gap_ci_low"] for y, (_, r) in zip(ys, mc, strict=True)],
                   [100 * r["gap_ci_high"] - y for y, (_, r) in zip(ys, mc, strict=True)]]
            ax.errorbar([at for at, _ in mc], ys, yerr=err, fmt="none", ecolor="tab:blue", elinewidth=0.8, capsize=2,
                        zorder=2)
            any_mc = True
        stat = [100 * r["statistical_gap"] for r in mine if r.get("statistical_gap") is not None]
        ax.scatter([x + 0.32] * len(stat), stat, s=22, facecolors="none", edgecolors="tab:orange", zorder=3)
    ax.scatter([], [], s=10, color="tab:blue", label="gap to the proven bound (exact or lossless)")
    if any_mc:
        ax.errorbar([], [], yerr=[], fmt="none", ecolor="tab:blue", capsize=2,
                    label="Monte Carlo value: gap at the estimate, bar: its CI's range")
    ax.scatter([], [], s=22, facecolors="none", edgecolors="tab:orange",
               label="statistical gap (information relaxation, not proven)")
    ax.legend(fontsize=6, loc="best")


def plot_sweep(sweep, rows: list[dict[str, Any]], path: Path, labels: dict[str, str] = SCHEMES,
               colours: dict[str, str] = COLOURS, proven: str = "dp", dashed: tuple[str, ...] = ("dp",),
               bold: str | None = None, ticks: bool = False) -> None:
    """Each method's mean (``rows`` as paper.py aggregates them) against the swept value:
    Q-learning with a band from the worst to the best seed, the ``proven`` row's bound as a
    band where some network is not certified, ``dashed`` the exact methods, ``bold`` one line."""
    fig, ax = start_figure(figsize=(6.0, 4.2))
    for m, label in labels.items():
        mine = [r for r in rows if r["method"] == m and r["mean"] is not None]
        if not mine:
            continue
        xs = [r["x"] for r in mine]
        ys = [r["mean"] for r in mine]
        ax.plot(xs, ys, label=label, color=colours[m], marker="o", ms=4, ls="--" if m in dashed else "-",
                lw=2.0 if m == bold else None)
        if m in RANDOMISED:
            ax.fill_between(xs, [r["seed_min"] for r in mine], [r["seed_max"] for r in mine],
                            color=colours[m], alpha=0.2, lw=0)
        if m == proven and any(r["certified"] is not None and r["certified"] < r["networks"]
                               and r["mean_bound"] is not None for r in mine):
            ax.fill_between(xs, ys, [r["mean"] if r["mean_bound"] is None else r["mean_bound"] for r in mine],
                            color="0.6", alpha=0.3, label="proven upper bound (not certified)")
    if sweep.log_x:
        ax.set_xscale("log")
    if ticks:
        ax.set_xticks(list(sweep.values))
    ax.set_yscale("log")
    ax.set_xlabel(sweep.x_label)
    ax.set_ylabel("time-average minimum VoI (bit/s)\nmean over networks; Q-learning: mean over seeds,\nband from the worst to the best seed", fontsize=8)
    ax.set_title(sweep.title, fontsize=8)
    ax.legend(fontsize=7)
    save_figure(fig, path)


# Fig. 8 (several robots): the best exact plan of dp and milp per network, then each method
ROBOT_LABELS = {"optimum": "best exact plan (dp, milp)", **SCHEMES, "dp": "dp", "milp": "milp", "greedy": "greedy"}
ROBOT_COLOURS_BY_METHOD = {**COLOURS, "optimum": "black", "dp": "0.45", "milp": "tab:brown", "greedy": "tab:purple"}


def plot_robots(sweep, rows: list[dict[str, Any]], path: Path) -> None:
    """Fig. 8: the optimum (with its proven bound as a band where not certified) and each
    method against the number of robots; Q-learning with its band over seeds."""
    plot_sweep(sweep, rows, path, ROBOT_LABELS, ROBOT_COLOURS_BY_METHOD, proven="optimum",
               dashed=("optimum", "dp", "milp"), bold="optimum", ticks=True)


def case_study_figures(inst: Instance, results: dict[str, Result], out: Path) -> list[Path]:
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


def instance_for(name: str | None, instance_path: str | None, file_path: str | None = None,
                 what: str = "result") -> tuple[Instance, str]:
    """The instance named ``name`` (a result's or a plan's ``instance``), and where it was
    found: given, or the first NAME.json beside the file, in an ``instances`` folder beside it,
    in the folder above it, or in ./instances, or the built-in case study."""
    if instance_path:
        inst, where = instance_mod.load(instance_path), str(instance_path)
    elif name is None:
        raise OptionError(f"--instance: give the instance of this {what} (it names none)")
    else:
        inst, where = _named_instance(name, file_path, what)
    if name is not None and inst.name != name:
        raise OptionError(f"--instance: the {what} is for {name!r}, the instance is {inst.name!r}")
    return inst, where


def _named_instance(name: str, file_path: str | None, what: str) -> tuple[Instance, str]:
    """``instance_for`` without --instance: NAME.json beside the file, in an ``instances`` folder
    beside it (a result saved in a clone's folder, its instance in instances/), in the folder
    above it, in ./instances, or the built-in case study."""
    file = f"{name}.json"
    here = None if file_path is None else Path(file_path).parent
    folders = [] if here is None else [here, here / "instances", here.parent]
    found = next((f / file for f in [*folders, Path("instances")]
                  if (f / file).is_file() and (file_path is None or not (f / file).samefile(file_path))), None)
    if found is not None:
        return instance_mod.load(found), str(found)
    if name == "case-study":
        return case_study(), "the built-in case study"
    itself = file_path is not None and any((f / file).is_file() for f in folders)  # the file's own name
    raise OptionError(f"--instance: give the instance of {what} {name!r} (no {file} beside the {what}"
                      f"{f' but the {what} itself' if itself else ''}, in instances/ beside it, in the folder above it "
                      "or in ./instances)")
