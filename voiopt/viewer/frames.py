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

from voiopt.core import physics
from voiopt.core.instance import Instance

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

    def __init__(self, instance: Instance, title: str = "", log_range: tuple[float, float] | None = None,
                 caption: str = ""):
        """``caption``: a line under every frame (the animation of a lossy plan says what it draws)."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.instance, self.title = instance, title
        self.lo, self.hi = log_range or voi_range(instance)
        self.figure = Figure(figsize=(SIZE_PX[0] / DPI, SIZE_PX[1] / DPI), dpi=DPI)
        self.canvas = FigureCanvasAgg(self.figure)
        self.ax = self.figure.add_axes((0.02, 0.04, 0.76, 0.86))
        self.bar = self.figure.add_axes((0.82, 0.12, 0.03, 0.7))
        self._colourbar()
        self._layout()
        if caption:
            self.figure.text(0.5, 0.008, caption, ha="center", va="bottom", fontsize=6.5, color="#a15c00")

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

    def _layout(self) -> None:
        """The fixed picture, drawn once: area, blocked points, ranges, starts, docks, sensors;
        and the artists each slot updates (paths, uploads, robots, sensor colours, title)."""
        from matplotlib.collections import PatchCollection
        from matplotlib.patches import Circle, Rectangle

        ax, inst, st = self.ax, self.instance, self.instance.step
        ax.add_patch(Rectangle((0, 0), inst.width, inst.height, facecolor="#fbfcfe", edgecolor="#c5ccd8", zorder=0))
        ax.add_collection(PatchCollection([Rectangle((x - st / 2, y - st / 2), st, st) for x, y in inst.blocked],
                                          facecolor="#4a5160", edgecolor="none", zorder=1))
        fleet = inst.n_robots > 1
        for k, r in enumerate(inst.robots):
            c = ROBOT_COLOURS[k % len(ROBOT_COLOURS)] if fleet else "#1d2330"
            ax.scatter(*r.start, marker="s", s=60, facecolor="none", edgecolor=c, zorder=2)
            if r.end is not None:
                ax.scatter(*r.end, marker="D", s=90, facecolor="none", edgecolor=c if fleet else "#1f7a44", lw=1.6, zorder=2)
        xy = np.array([s.position for s in inst.sensors], dtype=float)
        ax.add_collection(PatchCollection([Circle(s.position, inst.channel.d_th) for s in inst.sensors], facecolor="none",
                                          edgecolor="#9aa6b8", linestyle=":", linewidth=0.8, zorder=1))
        for i, s in enumerate(inst.sensors):
            if inst.n_sensors <= 12:
                ax.annotate(f"s{i}", s.position, xytext=(4, 4), textcoords="offset points", fontsize=7, zorder=6)
        self.sensors = ax.scatter(xy[:, 0], xy[:, 1], s=70, edgecolor="white", lw=1.0, zorder=5)
        self.paths, self.ups, self.now, self.robots = [], [], [], []
        for k in range(inst.n_robots):
            c = ROBOT_COLOURS[k % len(ROBOT_COLOURS)]
            self.paths.append(ax.plot([], [], color=c, lw=2.0, alpha=0.85, zorder=3)[0])
            self.ups.append(ax.scatter([], [], s=22, color=UPLOAD, edgecolor="white", lw=0.6, zorder=4))
            self.now.append(ax.plot([], [], color=UPLOAD, lw=1.4, ls="--", zorder=4)[0])
            self.robots.append(ax.scatter([], [], s=120, color=c, edgecolor="white", lw=1.5, zorder=7))
        self.heading = ax.set_title("", fontsize=8)
        ax.set_xlim(-0.5 * st, inst.width + 0.5 * st)
        ax.set_ylim(-0.5 * st, inst.height + 0.5 * st)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])

    def draw(self, slot: Slot) -> None:
        """Show one slot on the figure (replacing the last)."""
        inst, st = self.instance, self.instance.step
        self.sensors.set_facecolors([self.colour(v) for v in slot.voi])
        fleet = len(slot.xs) > 1
        for k in range(len(slot.xs)):
            shift = (k - (len(slot.xs) - 1) / 2) * 0.08 * st if fleet else 0.0
            xs, ys = np.asarray(slot.xs[k]) + shift, np.asarray(slot.ys[k]) + shift
            self.paths[k].set_data(xs, ys)
            up = np.asarray(slot.uploads[k]) >= 0
            self.ups[k].set_offsets(np.column_stack([xs[up], ys[up]]) if up.any() else np.empty((0, 2)))
            u = slot.uploads[k][-1]
            sx, sy = inst.sensors[u].position if u >= 0 else (xs[-1], ys[-1])  # uploading now: effect in slot t + 1
            self.now[k].set_data([xs[-1], sx] if u >= 0 else [], [ys[-1], sy] if u >= 0 else [])
            self.robots[k].set_offsets([[xs[-1], ys[-1]]])
        least = min(slot.voi) if slot.voi else math.nan
        self.heading.set_text(f"{self.title + '  ' if self.title else ''}slot t = {slot.t}   least VoI {least:.4g} bit/s")

    def rgb(self, slot: Slot) -> np.ndarray:
        """The slot as a (H, W, 3) uint8 array of SIZE_PX (height first)."""
        self.draw(slot)
        self.canvas.draw()
        return np.asarray(self.canvas.buffer_rgba())[:, :, :3].copy()


def slots_of(trajectory, instance: Instance):
    """The Slots t = 0..T-1 of a simulated trajectory (voiopt.core.simulate.Trajectory)."""
    from voiopt.grid import lattice

    pts = lattice.build(instance).points
    idx, sched = np.atleast_2d(trajectory.positions), np.atleast_2d(trajectory.schedule)
    for t in range(instance.horizon):
        yield Slot(t, tuple(tuple(pts[idx[k, : t + 1], 0].tolist()) for k in range(len(idx))),
                   tuple(tuple(pts[idx[k, : t + 1], 1].tolist()) for k in range(len(idx))),
                   tuple(tuple(sched[k, : t + 1].tolist()) for k in range(len(sched))),
                   tuple(trajectory.voi[t].tolist()), tuple(trajectory.aoi[t].tolist()))


def from_points(instance: Instance, t: int, points, uploads, aoi, dist) -> Slot:
    """The Slot t of lattice point indices (per robot, p_k(0..t)), uploads (per robot, -1: none)
    and the state's A_i(t), q_i(t): V_i(t) is physics.voi of them, as the simulator's."""
    from voiopt.grid import lattice

    pts = lattice.build(instance).points
    voi = physics.voi(np.asarray(aoi, dtype=np.int64), np.asarray(dist, dtype=float),
                      np.array([s.rho for s in instance.sensors]), np.array([s.power_w for s in instance.sensors]),
                      instance.channel)
    return Slot(t, tuple(tuple(pts[list(p), 0].tolist()) for p in points),
                tuple(tuple(pts[list(p), 1].tolist()) for p in points),
                tuple(tuple(int(u) for u in up) for up in uploads), tuple(voi.tolist()), tuple(int(a) for a in aoi))


GUI_BACKENDS = ("TkAgg", "QtAgg", "GTK4Agg", "GTK3Agg", "macosx")


class Window:
    """``render_mode="human"``: frames shown in a matplotlib window. Where no window can open
    (no display, no GUI toolkit), it warns once and shows nothing; it never raises."""

    def __init__(self, fps: float = 4.0):
        self.fps, self.figure, self.image, self.failed = fps, None, None, None

    def _open(self) -> str | None:
        """Open the window; the reason it cannot, or None."""
        import os
        import sys

        if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            return "no display (DISPLAY and WAYLAND_DISPLAY are not set)"
        import matplotlib.pyplot as plt

        why = []
        for backend in GUI_BACKENDS:
            try:
                plt.switch_backend(backend)
                self.figure = plt.figure("voiopt", figsize=(SIZE_PX[0] / DPI, SIZE_PX[1] / DPI), dpi=DPI)
                self.figure.add_axes((0, 0, 1, 1)).set_axis_off()
                return None
            except Exception as e:  # any toolkit may fail its own way (no Tk, no Qt, display refused)
                why.append(f"{backend}: {e}".splitlines()[0][:120])
        plt.switch_backend("Agg")
        return f"no GUI toolkit for matplotlib ({why[0]}; and {len(why) - 1} more)"

    def show(self, rgb: np.ndarray) -> None:
        import warnings

        if self.failed is None:
            self.failed = self._open() or False
            if self.failed:
                warnings.warn(f"render_mode='human' shows nothing here: {self.failed}; use render_mode='rgb_array' "
                              "for frames", RuntimeWarning, stacklevel=4)
        if self.failed:
            return
        import matplotlib.pyplot as plt

        try:
            if self.image is None:
                self.image = self.figure.axes[0].imshow(rgb)
                plt.show(block=False)
            else:
                self.image.set_data(rgb)
            plt.pause(1.0 / self.fps)
        except Exception as e:  # the window was closed, the display went away
            self.failed = str(e).splitlines()[0] if str(e) else type(e).__name__
            warnings.warn(f"render_mode='human' stopped showing frames: {self.failed}", RuntimeWarning, stacklevel=4)

    def close(self) -> None:
        if self.figure is not None:
            import matplotlib.pyplot as plt

            plt.close(self.figure)
            self.figure = self.image = None
