"""One picture of one slot, drawn with matplotlib: the area, blocked points, docks, sensors
coloured by their VoI, each robot's path so far with its uploads, and the slot number.

The one drawing of a slot in voiopt: ``voiopt plot --animate`` (voiopt/viewer/animate.py)
draws a frame per slot with it, and the Gymnasium and PettingZoo envs' ``rgb_array`` and
``human`` renders are its frames. Every value drawn is given (the simulator's, or the env's
state); nothing is computed here but colours and positions."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from voiopt import physics
from voiopt.instance import Instance

ROBOT_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#17becf")
UPLOAD = "#d62728"
SIZE_PX = (480, 400)  # width, height of every frame (a fixed shape: videos need one)
DPI = 100


@dataclass(frozen=True)
class Slot:
    """What a frame shows: slot t, each robot's points p_k(0..t) and uploads u_k(0..t) (-1 or
    None: none; the last one is slot t's, taking effect in slot t + 1), and V_i(t), A_i(t)."""

    t: int
    xs: tuple[tuple[float, ...], ...]  # per robot, p_k(s) x for s = 0..t
    ys: tuple[tuple[float, ...], ...]
    uploads: tuple[tuple[int, ...], ...]  # per robot, u_k(s) for s = 0..t, -1 for none
    voi: tuple[float, ...]  # V_i(t)
    aoi: tuple[int, ...]  # A_i(t)


def voi_range(instance: Instance) -> tuple[float, float]:
    """log10 of the VoI range that colours use, from the instance alone (so that every frame
    of an episode or an animation has one scale): a fresh upload from d_th / 10 at age 1, and
    the oldest packet of the horizon from the farthest distance; clipped beyond."""
    rho = np.array([s.rho for s in instance.sensors])
    power = np.array([s.power_w for s in instance.sensors])
    d_th = instance.channel.d_th
    far = max([d_th] + [instance.initial_distance(i) for i in range(instance.n_sensors)])
    oldest = max(s.initial_aoi for s in instance.sensors) + instance.horizon
    hi = physics.voi(np.ones_like(rho, dtype=np.int64), np.full_like(rho, d_th / 10), rho, power, instance.channel)
    lo = physics.voi(np.full(rho.shape, oldest, dtype=np.int64), np.full_like(rho, far), rho, power, instance.channel)
    good = lambda v: v[np.isfinite(v) & (v > 0)]  # noqa: E731
    top = math.log10(good(hi).max()) if good(hi).size else 0.0
    bottom = math.log10(good(lo).min()) if good(lo).size else top - 1
    return math.floor(min(bottom, top - 1)), math.ceil(top)


class Painter:
    """Draws Slots of one instance on one reused figure of SIZE_PX pixels (Agg)."""

    def __init__(self, instance: Instance, title: str = "", log_range: tuple[float, float] | None = None):
        from matplotlib.figure import Figure

        self.instance, self.title = instance, title
        self.lo, self.hi = log_range or voi_range(instance)
        self.figure = Figure(figsize=(SIZE_PX[0] / DPI, SIZE_PX[1] / DPI), dpi=DPI)
        self.ax = self.figure.add_axes((0.02, 0.04, 0.76, 0.86))
        self.bar = self.figure.add_axes((0.82, 0.12, 0.03, 0.7))
        self._colourbar()

    def _colourbar(self) -> None:
        from matplotlib import colormaps

        grad = np.linspace(self.lo, self.hi, 128)[:, None]
        self.bar.imshow(grad, origin="lower", aspect="auto", cmap=colormaps["viridis"],
                        extent=(0, 1, self.lo, self.hi))
        self.bar.set_xticks([])
        self.bar.yaxis.tick_right()
        self.bar.set_title("log10 V\n(bit/s)", fontsize=7)
        self.bar.tick_params(labelsize=7)

    def colour(self, v: float):
        from matplotlib import colormaps

        f = 1.0 if not math.isfinite(v) or v <= 0 else (math.log10(v) - self.lo) / (self.hi - self.lo)
        return colormaps["viridis"](min(1.0, max(0.0, f)))

    def draw(self, slot: Slot) -> None:
        """Draw one slot on the figure (replacing the last)."""
        from matplotlib.patches import Circle, Rectangle

        ax, inst = self.ax, self.instance
        ax.clear()
        st = inst.step
        ax.add_patch(Rectangle((0, 0), inst.width, inst.height, facecolor="#fbfcfe", edgecolor="#c5ccd8", zorder=0))
        for x, y in inst.blocked:
            ax.add_patch(Rectangle((x - st / 2, y - st / 2), st, st, color="#4a5160", zorder=1))
        fleet = inst.n_robots > 1
        for k, r in enumerate(inst.robots):
            c = ROBOT_COLOURS[k % len(ROBOT_COLOURS)] if fleet else "#1d2330"
            ax.scatter(*r.start, marker="s", s=60, facecolor="none", edgecolor=c, zorder=2)
            if r.end is not None:
                ax.scatter(*r.end, marker="D", s=90, facecolor="none", edgecolor=c if fleet else "#1f7a44", lw=1.6, zorder=2)
        for i, s in enumerate(inst.sensors):
            ax.add_patch(Circle(s.position, inst.channel.d_th, fill=False, ls=":", lw=0.8, color="#9aa6b8", zorder=1))
            ax.scatter(*s.position, s=70, color=self.colour(slot.voi[i]), edgecolor="white", lw=1.0, zorder=5)
            if inst.n_sensors <= 12:
                ax.annotate(f"s{i}", s.position, xytext=(4, 4), textcoords="offset points", fontsize=7, zorder=6)
        for k in range(len(slot.xs)):
            c = ROBOT_COLOURS[k % len(ROBOT_COLOURS)]
            shift = (k - (len(slot.xs) - 1) / 2) * 0.08 * st if fleet else 0.0
            xs, ys = np.asarray(slot.xs[k]) + shift, np.asarray(slot.ys[k]) + shift
            ax.plot(xs, ys, color=c, lw=2.0, alpha=0.85, zorder=3)
            up = np.flatnonzero(np.asarray(slot.uploads[k]) >= 0)
            ax.scatter(xs[up], ys[up], s=22, color=UPLOAD, edgecolor="white", lw=0.6, zorder=4)
            u = slot.uploads[k][-1]
            if u >= 0:  # uploading now: takes effect in slot t + 1
                sx, sy = inst.sensors[u].position
                ax.plot([xs[-1], sx], [ys[-1], sy], color=UPLOAD, lw=1.4, ls="--", zorder=4)
            ax.scatter(xs[-1], ys[-1], s=120, color=c, edgecolor="white", lw=1.5, zorder=7)
        least = min(slot.voi) if slot.voi else math.nan
        ax.set_title(f"{self.title + '  ' if self.title else ''}slot t = {slot.t}   least VoI {least:.4g} bit/s",
                     fontsize=8)
        ax.set_xlim(-0.5 * st, inst.width + 0.5 * st)
        ax.set_ylim(-0.5 * st, inst.height + 0.5 * st)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])

    def rgb(self, slot: Slot) -> np.ndarray:
        """The slot as a (H, W, 3) uint8 array of SIZE_PX (height first)."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        self.draw(slot)
        canvas = FigureCanvasAgg(self.figure)
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()


def slots_of(trajectory, instance: Instance):
    """The Slots t = 0..T-1 of a simulated trajectory (voiopt.simulate.Trajectory)."""
    from voiopt import lattice

    pts = lattice.build(instance).points
    idx, sched = np.atleast_2d(trajectory.positions), np.atleast_2d(trajectory.schedule)
    for t in range(instance.horizon):
        yield Slot(t, tuple(tuple(pts[idx[k, : t + 1], 0].tolist()) for k in range(len(idx))),
                   tuple(tuple(pts[idx[k, : t + 1], 1].tolist()) for k in range(len(idx))),
                   tuple(tuple(sched[k, : t + 1].tolist()) for k in range(len(sched))),
                   tuple(trajectory.voi[t].tolist()), tuple(trajectory.aoi[t].tolist()))
