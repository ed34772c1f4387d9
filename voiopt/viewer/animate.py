"""``voiopt plot RESULT --animate -o out.gif``: one frame a slot, t = 0..T-1, each showing its
slot number (voiopt/viewer/frames.py draws them), written with matplotlib.animation: Pillow
for a GIF, ffmpeg for an MP4 (where ffmpeg is installed; else a one-line error)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from voiopt.core.instance import Instance
from voiopt.errors import OptionError
from voiopt.runtime.files import atomic_path
from voiopt.runtime.progress import progress_bar
from voiopt.viewer.frames import DPI, Painter, slots_of
from voiopt.viewer.story import Entry, lossy_caption, trajectory

MOVIE_FORMATS = (".gif", ".mp4")


def check_movie_path(path: str | os.PathLike) -> str:
    """The format of an animation file from its suffix (.gif or .mp4, which needs ffmpeg)."""
    suffix = Path(path).suffix.lower()
    if suffix not in MOVIE_FORMATS:
        raise OptionError(f"-o/--output: {str(path)!r}: an animation is written as .gif or .mp4, got "
                          f"{suffix or 'no suffix'!r}")
    if suffix == ".mp4" and shutil.which("ffmpeg") is None:
        raise OptionError(f"-o/--output: {str(path)!r}: an .mp4 needs ffmpeg, which is not installed here; "
                          "write a .gif instead (or install ffmpeg)")
    return suffix[1:]


def animate(instance: Instance, entry: Entry, path: str | os.PathLike, where: str = "the instance",
            fps: float = 4.0, progress: bool = True) -> None:
    """Write the animation of one plan: T frames, frame t the slot t (positions p_k(0..t),
    V_i(t) before slot t's upload takes effect). On a lossy instance the frames are the run in
    which every upload succeeds, and each frame says so (``lossy_caption``); a policy result has
    no plan and is refused. A Ctrl-C stops it and leaves no file (the temporary file is removed)."""
    from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter

    if not fps > 0:
        raise OptionError(f"--fps: must be > 0, got {fps!r}")
    fmt = check_movie_path(path)
    traj = trajectory(instance, entry, where)
    title = f"{entry.method or entry.label}"
    painter = Painter(instance, title, caption=lossy_caption(instance))
    slots = list(slots_of(traj, instance))
    with progress_bar(progress) as bar:
        task = bar.add_task(f"frames of {instance.name}", total=len(slots))

        def frame(t: int):
            painter.draw(slots[t])
            bar.update(task, completed=t + 1)
            return []

        movie = FuncAnimation(painter.figure, frame, frames=len(slots), blit=False, repeat=False)
        writer = PillowWriter(fps=fps) if fmt == "gif" else FFMpegWriter(fps=fps)
        with atomic_path(path) as tmp:
            movie.save(tmp, writer=writer, dpi=DPI)
