"""Figures and trajectory plots (smoke: files exist and hold the numbers plotted)."""

from __future__ import annotations

import csv
import itertools

import hypothesis.strategies as st
from hypothesis import given

import voiopt
from voiopt.cli.main import main
from voiopt.experiments.paper import ROBOT_METHODS, ROBOTS, SWEEPS
from voiopt.experiments.plots import SCHEMES


def test_plot_a_result(tmp_path, capsys, case_study):
    result = voiopt.solve(case_study, method="greedy", objective="mean-min-voi")
    result.save(tmp_path / "r.json")
    png = tmp_path / "r.png"
    assert main(["plot", str(tmp_path / "r.json"), "--instance", "instances/case-study.json", "-o", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    other = voiopt.generate(2, 5, seed=1)
    voiopt.save(other, tmp_path / "other.json")
    assert main(["plot", str(tmp_path / "r.json"), "--instance", str(tmp_path / "other.json"), "-o", str(png)]) == 2
    assert "the result is for 'case-study'" in capsys.readouterr().err


def test_figures_smoke(tmp_path, capsys):
    out = tmp_path / "figs"
    assert main(["figures", "--out", str(out), "--networks", "1", "--robot-networks", "1", "--episodes", "2000",
                 "--time-limit", "0.3"]) == 0
    err = capsys.readouterr().err  # not a terminal: a line per finished setting
    assert "finished: case study" in err and "finished: fig7_nodes number of nodes N = 8 (" in err
    for name in ["fig3_case_study", "fig4_voi_over_time", *(s.key for s in SWEEPS)]:
        assert (out / f"{name}.png").stat().st_size > 5000, name
        assert (out / f"{name}.csv").is_file(), name
    for sweep in SWEEPS:
        with open(out / f"{sweep.key}.csv") as f:
            header = [line for line in f if line.startswith("#")]
            f.seek(0)
            rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
        assert any("sweep values" in h for h in header)
        assert len(rows) == len(sweep.values) * len(SCHEMES)
        assert all(int(r["networks"]) == 1 and r["mean"] for r in rows)
        assert all(r["ci95"] == "" for r in rows)  # over networks, not over the seeds too: none from one network
    md = (out / "figures.md").read_text()
    assert "fig7_nodes.png" in md and "| dp (the optimum where certified) | dp certified |" in md
    assert "| K | best exact plan (networks certified optimal) | proven bound |" in md
    with open(out / "fig8_robots.csv") as f:  # several robots: the optimum and every method per K
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    assert [int(r["x"]) for r in rows] == [k for k in ROBOTS.values for _ in range(1 + len(ROBOT_METHODS))]
    for r in rows:  # every method plans for 1, 2 and 3 robots here, but dp declines 3 (one error per network)
        declines = r["method"] == "dp" and r["x"] == "3"
        assert bool(r["mean"]) != declines and (r["errors"] == "1") == declines, r
    assert (out / "fig8_robots.png").stat().st_size > 5000 and "fig8_robots.png" in md


def test_a_fleet_plot_gives_each_robot_its_colour_and_marks_its_uploads(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    from voiopt.experiments.plots import ROBOT_COLOURS, draw_plan

    inst = voiopt.generate(6, 12, seed=3, robots=3, dock=True, end="start", max_moves=8)
    result = voiopt.solve(inst, "greedy")
    fig, ax = plt.subplots()
    draw_plan(ax, inst, result.plan)
    paths = [line for line in ax.lines if line.get_label() in ("robot 0", "robot 1", "robot 2")]
    assert [line.get_label() for line in paths] == ["robot 0", "robot 1", "robot 2"]
    assert [line.get_color() for line in paths] == list(ROBOT_COLOURS[:3])
    uploads = sorted((t, u) for r in result.plan.robots for t, u in enumerate(r.schedule) if u is not None)
    labels = [t.get_text() for t in ax.texts if t.get_text().startswith("t")]  # not the sensors' own
    assert uploads and sorted(pair for text in labels for pair in _uploads_of(text)) == uploads
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert sum("max_moves 8" in t for t in legend) == 3
    plt.close(fig)
    result.save(tmp_path / "r.json")
    voiopt.save(inst, tmp_path / "i.json")
    assert main(["plot", str(tmp_path / "r.json"), "--instance", str(tmp_path / "i.json"),
                 "-o", str(tmp_path / "r.png")]) == 0
    assert (tmp_path / "r.png").stat().st_size > 10_000


def _uploads_of(label: str) -> list[tuple[int, int]]:
    """The (slot, sensor) pairs a label of draw_plan names: lines t3:s0, t3-9:s0 or t1-3,7:s0."""
    pairs = []
    for line in label.splitlines():
        slots, sensor = line.split(":s")
        for r in slots[1:].split(","):
            first, _, last = r.partition("-")
            pairs += [(t, int(sensor)) for t in range(int(first), int(last or first) + 1)]
    return pairs


def test_uploads_at_one_point_share_one_label_that_names_each_slot():
    from voiopt.core.plan import Plan
    from voiopt.experiments.plots import upload_labels

    a, b = (1.0, 3.0), (2.0, 3.0)
    positions = [(0.0, 3.0), a, a, a, a, b, a, a]
    schedule = [None, 0, 0, 0, 1, 2, None, 0]
    labels = upload_labels(Plan(tuple(positions), tuple(schedule)))
    assert labels == {a: "t1-3,7:s0\nt4:s1", b: "t5:s2"}  # one line per sensor
    assert sorted(p for text in labels.values() for p in _uploads_of(text)) == \
        sorted((t, u) for t, u in enumerate(schedule) if u is not None)


@given(st.lists(st.tuples(st.integers(0, 2), st.one_of(st.none(), st.integers(0, 3))), min_size=1, max_size=60))
def test_upload_labels_name_every_upload_once_in_a_line_per_sensor_and_few_ranges(steps):
    """A long stay that alternates sensors used to get one line per visit (a review of the
    fleet plot, 2026-12-03): now each line is one sensor's, with at most RANGES_PER_LINE ranges."""
    from voiopt.core.plan import Plan
    from voiopt.experiments.plots import RANGES_PER_LINE, upload_labels

    positions, schedule = tuple((float(x), 0.0) for x, _ in steps), tuple(u for _, u in steps)
    labels = upload_labels(Plan(positions, schedule))
    named = [(t, u, point) for point, text in labels.items() for t, u in _uploads_of(text)]
    assert sorted(named) == sorted((t, u, positions[t]) for t, u in enumerate(schedule) if u is not None)
    for point, text in labels.items():
        sensors = [line.split(":s")[1] for line in text.splitlines()]
        assert all(line.count(",") < RANGES_PER_LINE for line in text.splitlines())
        for u in set(sensors):  # a sensor's lines are together, as few as its runs of slots there need
            here = [t for t in range(len(schedule)) if schedule[t] == int(u) and positions[t] == point]
            runs = 1 + sum(b != a + 1 for a, b in itertools.pairwise(here))
            first, count = sensors.index(u), sensors.count(u)
            assert sensors[first: first + count] == [u] * count and count == -(-runs // RANGES_PER_LINE)


def test_a_robot_that_stays_and_uploads_every_slot_gets_one_label():
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    from voiopt.core.plan import Plan
    from voiopt.experiments.plots import draw_plan

    inst = voiopt.generate(3, 10, seed=1)
    plan = Plan(tuple([inst.start] * inst.horizon), tuple([0] * inst.horizon))
    fig, ax = plt.subplots()
    draw_plan(ax, inst, plan)
    assert [t.get_text() for t in ax.texts if t.get_text().startswith("t")] == [f"t0-{inst.horizon - 1}:s0"]
    plt.close(fig)


def test_the_confidence_interval_over_few_networks_uses_students_t():
    """1.96 s / sqrt(n) was reported: 6.5 times too narrow at 2 networks (an independent check
    of the figures, 2026-12-03). t(0.975; 2) = 4.3027, t(0.975; 4) = 2.7764 (tables)."""
    import math

    import pytest

    from voiopt.experiments.paper import ci95

    assert ci95([1.0, 2.0, 3.0]) == pytest.approx(4.3027 / math.sqrt(3), rel=1e-4)  # sd 1
    assert ci95([2.0, 4.0, 4.0, 4.0, 6.0]) == pytest.approx(2.7764 * math.sqrt(2) / math.sqrt(5), rel=1e-4)
    assert ci95([5.0]) is None


def _drawn(inst, plan):
    """draw_plan's figure as saved (tight layout, drawn): its markers' and labels' boxes in
    display units, and the sensors' marker path."""
    import math

    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt
    from matplotlib.transforms import Bbox

    from voiopt.experiments.plots import draw_plan

    fig, ax = plt.subplots(figsize=(5.2, 5.2))
    draw_plan(ax, inst, plan, "a title")
    fig.tight_layout()
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    px = fig.dpi / 72
    markers, sensor_paths = [], []
    sensors = {tuple(s.position) for s in inst.sensors}
    for coll in ax.collections:
        sizes = coll.get_sizes() if hasattr(coll, "get_sizes") else []
        if len(sizes) == 0 or max(sizes) <= 4:  # the lattice's dots, the blocked squares' patches
            continue
        for (x, y), s in zip(coll.get_offsets(), itertools.cycle(sizes), strict=False):
            cx, cy = ax.transData.transform((x, y))
            half = math.sqrt(s) / 2 * px
            markers.append(Bbox.from_extents(cx - half, cy - half, cx + half, cy + half))
            if (float(x), float(y)) in sensors:
                sensor_paths.append(coll.get_paths()[0])
    labels = [(t.get_text(), t.get_window_extent(renderer)) for t in ax.texts]
    plt.close(fig)
    return markers, labels, sensor_paths


def test_the_plot_s_labels_cover_no_marker_and_no_label_and_sensors_are_not_crosses():
    """A review (2026-12-05): sensors were red x, the viewer's mark of a failed upload, and a
    sensor's name sat on an upload label and a path marker (the dp plan of generate(3, 10,
    seed=3)). Sensors are now hexagons, and every label goes where it covers nothing."""
    import numpy as np
    from matplotlib.markers import MarkerStyle

    from voiopt.core.plan import Plan

    x = MarkerStyle("x")
    cross = x.get_path().transformed(x.get_transform()).vertices  # as scatter stores a marker
    net = voiopt.generate(3, 10, seed=3)
    dp_plan = Plan(((0, 0), (1, 0), (2, 0), (3, 0), (3, 1), (2, 1), (1, 1), (2, 1), (3, 1), (3, 0)),
                   (None, None, 2, 1, 1, 2, 0, 2, 1, 1))
    six = voiopt.generate(6, 30, seed=5)
    case = voiopt.load("instances/case-study.json")
    for inst, plan in ((net, dp_plan), (six, voiopt.solve(six, "greedy").plan),
                       (case, voiopt.load_plan("instances/case-study.plan.json"))):
        markers, labels, sensor_paths = _drawn(inst, plan)
        assert len(sensor_paths) == inst.n_sensors
        assert not any(p.vertices.shape == cross.shape and np.allclose(p.vertices, cross) for p in sensor_paths)
        assert len(labels) >= inst.n_sensors + 1
        for k, (text, box) in enumerate(labels):
            assert not any(box.overlaps(m) for m in markers), (inst.name, text)
            assert not any(box.overlaps(other) for _, other in labels[k + 1:]), (inst.name, text)
