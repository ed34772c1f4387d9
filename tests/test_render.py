"""The envs' render modes (voiopt/viewer/frames.py draws every frame): rgb_array frames of one
fixed shape, "human" without a display (a warning once, nothing drawn, no error), Gymnasium's
RecordVideo, PettingZoo's render_test."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import voiopt

gymnasium = pytest.importorskip("gymnasium")
pytest.importorskip("pettingzoo")

from voiopt import env as voienv  # noqa: E402
from voiopt.viewer import frames  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def _episode(env, seed=0):
    """Step the env through an episode with the first legal action, rendering every slot."""
    env.reset(seed=seed)
    out = [env.render()]
    done = False
    while not done:
        a = int(np.flatnonzero(env.action_masks())[0])
        _, _, done, _, _ = env.step(a)
        out.append(env.render())
    return out


@pytest.mark.parametrize("name", ["case-study", "dock", "fleet", "factory"])
def test_rgb_array_frames_have_one_fixed_shape(name):
    inst = voiopt.load(ROOT / "instances" / f"{name}.json")
    if inst.horizon > 30:  # the factory floor (T = 100): a short episode is enough to see the frame's shape
        inst = inst.replace(horizon=12)
    env = voienv.VoIEnv(inst, render_mode="rgb_array")
    shots = _episode(env)
    assert len(shots) == inst.horizon + 1
    for img in shots:
        assert img.dtype == np.uint8 and img.shape == (frames.SIZE_PX[1], frames.SIZE_PX[0], 3)
    assert any((a != b).any() for a, b in zip(shots, shots[1:], strict=False))  # the robots move, the colours change


def test_frame_shows_what_the_state_holds(case_study):
    """The frame's VoI is physics.voi of the env's state: at the end of an episode, the simulated
    row T of its plan."""
    env = voienv.VoIEnv(case_study, render_mode="rgb_array")
    _episode(env)
    slot = env.current_slot()
    traj = voiopt.simulate(case_study, env.plan())
    assert slot.t == case_study.horizon
    np.testing.assert_array_equal(slot.voi, traj.voi[-1])
    assert list(slot.aoi) == traj.aoi[-1].tolist()
    assert [list(zip(x, y, strict=True)) for x, y in zip(slot.xs, slot.ys, strict=True)][0][:-1] == list(env.plan().positions)


def test_human_without_a_display_warns_once_and_renders_nothing(case_study, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    env = voienv.VoIEnv(case_study, render_mode="human")
    env.reset()
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        assert env.render() is None
        env.step(int(np.flatnonzero(env.action_masks())[0]))
        assert env.render() is None
    assert len(seen) == 1 and "render_mode='human' shows nothing here: no display" in str(seen[0].message)
    env.close()


def test_record_video_records_an_episode(case_study, tmp_path):
    pytest.importorskip("moviepy")
    from gymnasium.wrappers import RecordVideo

    env = RecordVideo(gymnasium.make(voienv.ENV_ID, instance=case_study, render_mode="rgb_array"),
                      str(tmp_path / "videos"), episode_trigger=lambda k: True, disable_logger=True)
    env.reset(seed=0)
    done = False
    while not done:
        _, _, done, _, _ = env.step(int(np.flatnonzero(env.unwrapped.action_masks())[0]))
    env.close()
    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000


def test_pettingzoo_render_test_passes(monkeypatch):
    from pettingzoo.test import render_test
    from pettingzoo.utils.conversions import parallel_to_aec

    from voiopt.pz_env import parallel_env

    monkeypatch.delenv("DISPLAY", raising=False)  # "human" here: the warning, nothing drawn
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    inst = voiopt.load(ROOT / "instances" / "fleet.json")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        render_test(lambda render_mode=None: parallel_to_aec(parallel_env(instance=inst, render_mode=render_mode)))


HUMAN = """
import warnings, numpy as np, matplotlib.pyplot as plt, voiopt
from voiopt import env as voienv
warnings.simplefilter("error")  # a warning would mean no window
env = voienv.VoIEnv(voiopt.load({case!r}), render_mode="human")
env.reset()
for _ in range(3):
    assert env.render() is None
    env.step(int(np.flatnonzero(env.action_masks())[0]))
figure = plt.gcf()
assert plt.get_backend().lower() != "agg" and figure.axes[0].images, plt.get_backend()
assert figure.axes[0].images[0].get_array().shape[:2] == (400, 480)
env.close()
print("window ok")
"""


def test_human_shows_a_window_on_a_display(tmp_path):
    """On an X display (a virtual one, Xvfb, where installed) the frames go to a window."""
    import os
    import shutil
    import subprocess
    import sys
    import time

    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb): the window is not tested here")
    pytest.importorskip("tkinter", reason="no Tk for matplotlib's window (apt-get install python3-tk)")
    display = f":{os.getpid() % 500 + 100}"
    server = subprocess.Popen([xvfb, display, "-screen", "0", "800x600x24"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    try:
        time.sleep(1.0)  # the server's start (a wait, not a timed assertion)
        env = {**{k: v for k, v in os.environ.items() if k != "MPLBACKEND"}, "DISPLAY": display}
        proc = subprocess.run([sys.executable, "-c", HUMAN.format(case=str(ROOT / "instances" / "case-study.json"))],
                              env=env, capture_output=True, text=True, timeout=120)
    finally:
        server.terminate()
        server.wait(timeout=10)
    assert proc.returncode == 0 and "window ok" in proc.stdout, proc.stderr
