"""The field model from the command line and the generator: options, the factory preset, the
shipped examples, and one-line errors with exit status 2."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import ROOT, run_cli
from oracles import model_oracle as oracle
from test_cli import one_line_error

import voiopt
from voiopt.errors import OptionError
from voiopt.grid import lattice
from voiopt.networks import fields

DOCK = str(ROOT / "instances" / "dock.json")
FACTORY = str(ROOT / "instances" / "factory.json")


def test_generated_fields_follow_the_options():
    for seed in range(10):
        inst = voiopt.generate(4, 20, width=6.0, height=6.0, seed=seed, blocked_fraction=0.25, end="random",
                               max_moves=15)
        lat = lattice.build(inst)
        assert len(inst.blocked) == round(0.25 * lat.n_points)
        free = ~lat.blocked
        assert (lat.from_start[free] < lattice.UNREACHABLE).all()  # the free points stay connected
        assert inst.end is not None and lat.from_start[lat.end] <= 15 and inst.max_moves == 15
        oracle.check_instance(inst.to_dict())
    assert voiopt.generate(3, 10, seed=1, end="start").end == voiopt.generate(3, 10, seed=1).start
    assert voiopt.generate(3, 10, seed=1, end=(2, 3)).end == (2.0, 3.0)


def test_paper_networks_are_unchanged_by_the_new_options():
    plain = voiopt.generate(4, 30, seed=5)
    assert voiopt.generate(4, 30, seed=5, blocked_fraction=0.0, end=None, max_moves=None) == plain
    fielded = voiopt.generate(4, 30, seed=5, blocked_fraction=0.2, end="start", max_moves=10)
    assert fielded.sensors == plain.sensors and fielded.start == plain.start


def test_factory_preset():
    insts = voiopt.generate_set(4, seed=2, preset="factory")
    assert len({i.n_sensors for i in insts}) > 1
    for inst in insts:
        lat = lattice.build(inst)
        assert (inst.width, inst.height, inst.horizon, inst.max_moves) == (20.0, 20.0, 100, 80)
        assert inst.start == inst.end == (0.0, 0.0)
        assert 10 <= inst.n_sensors <= 30
        assert all(0.6 <= s.rho <= 0.99 for s in inst.sensors)
        assert set(inst.blocked) == {(float(x), float(y)) for x, y in fields.factory_blocked()}
        assert (lat.in_range & ~lat.blocked).any(axis=1).all()  # every sensor can be collected
        assert (lat.from_start[~lat.blocked] < lattice.UNREACHABLE).all()
    assert fields.factory(15, 50, seed=1, max_moves=None).n_sensors == 15


@pytest.mark.parametrize("kwargs, message", [
    (dict(blocked_fraction=1.0), "blocked-fraction: must be a number in [0, 1), got 1.0"),
    (dict(end="dock"), "end: must be 'start', 'random' or a point X,Y, got 'dock'"),
    (dict(max_moves=-2), "max-moves: must be an integer >= 0, got -2"),
    (dict(width=200.0, height=200.0, blocked_fraction=0.1), "blocked-fraction: random obstacles need a lattice of"),
])
def test_bad_generator_options(kwargs, message):
    with pytest.raises(OptionError, match=message.replace("[", r"\[").replace("(", r"\(").replace(")", r"\)")):
        voiopt.generate(3, 10, **kwargs)


def test_generate_command_with_fields(capsys, tmp_path):
    code, out, _ = run_cli(capsys, "generate", "--sensors", "3", "--blocked-fraction", "0.2", "--end", "start",
                       "--max-moves", "9", "--seed", "4")
    d = json.loads(out)
    assert code == 0 and d["end"] == d["start"] and d["max_moves"] == 9 and len(d["blocked"]) == round(0.2 * 36)
    code, out, _ = run_cli(capsys, "generate", "--preset", "factory", "--sensors", "11", "--count", "2", "--out",
                       str(tmp_path))
    assert code == 0
    for path in sorted(tmp_path.glob("*.json")):
        inst = voiopt.load(path)
        assert inst.n_sensors == 11 and inst.end == (0.0, 0.0) and inst.horizon == 100


@pytest.mark.parametrize("argv, message", [
    (["generate", "--end", "nowhere"], "voiopt: error: --end: must be start, random or X,Y, got 'nowhere'"),
    (["generate", "--end", "9,9"], "voiopt: error: end: must lie in the area [0, 5] x [0, 5], got [9.0, 9.0]"),
    (["generate", "--preset", "factory", "--rho", "0.1", "0.2"],
     "voiopt: error: --rho: the factory preset fixes the floor, racks, dock and sensors; it takes --sensors, "
     "--horizon, --max-moves and --robots"),
    (["generate", "--max-moves", "-1"], "voiopt: error: max-moves: must be an integer >= 0, got -1"),
])
def test_generate_errors_are_one_line(capsys, argv, message):
    code, out, err = run_cli(capsys, *argv)
    assert code == 2 and out == ""
    assert one_line_error(err) == message


def test_impossible_instance_and_illegal_plan_exit_2(capsys, tmp_path):
    d = json.loads(open(DOCK).read())
    d["max_moves"] = 15
    tight = tmp_path / "dock-tight.json"
    tight.write_text(json.dumps(d))
    code, _, err = run_cli(capsys, "validate", str(tight))
    assert code == 2
    assert one_line_error(err) == (f"{tight}: end: [4, 4] is not reachable within 15 moves (max_moves is 15): it is "
                                   "16 moves from start [0, 0] around the blocked points")
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps({"positions": [[0, 0]] * 30, "schedule": [None] * 30}))
    code, _, err = run_cli(capsys, "evaluate", DOCK, str(plan))
    assert code == 2
    assert one_line_error(err) == f"voiopt: error: {plan}: positions[29]: must equal end [4, 4] in the last slot, got [0, 0]"


def test_shipped_examples(capsys, tmp_path):
    dock = voiopt.load(DOCK)
    r = voiopt.solve(dock, "dp", "mean-min-voi")
    assert r.status == "optimal" and r.plan.positions[-1] == (4.0, 4.0)
    factory = voiopt.load(FACTORY)
    shipped = voiopt.load_result(ROOT / "instances" / "factory.result.json")
    metrics = voiopt.evaluate(factory, shipped.plan)  # the shipped plan is legal and gives its stated value
    assert metrics[shipped.objective] == pytest.approx(shipped.value, rel=1e-12)
    assert shipped.bound >= shipped.value
    out = tmp_path / "factory.png"
    code, _, _ = run_cli(capsys, "plot", str(ROOT / "instances" / "factory.result.json"), "--instance", FACTORY,
                     "-o", str(out))
    assert code == 0 and out.stat().st_size > 10_000
    assert np.isfinite(metrics["mean-min-voi"])


def test_validate_and_generate_say_when_a_sensor_is_never_uploaded(capsys, tmp_path):
    """A budget too short for a sensor's round trip leaves it stranded: every plan's value is
    then fixed by its ageing packet, so the user is told (exit 0: the instance is legal)."""
    code, out, err = run_cli(capsys, "generate", "--preset", "factory", "--sensors", "6", "--horizon", "30",
                         "--max-moves", "20", "--count", "2", "--seed", "1", "--out", str(tmp_path / "f"))
    assert code == 0 and "note: 2 of 2 network(s)" in err and "voiopt validate names them" in err
    path = sorted((tmp_path / "f").glob("*.json"))[0]
    inst = voiopt.load(path)
    stranded = lattice.stranded_sensors(inst)
    code, out, _ = run_cli(capsys, "validate", str(path))
    assert code == 0 and out.startswith("ok (warning: sensors ") and f"{stranded} are never uploaded" in out
    code, _, err = run_cli(capsys, "generate", "--preset", "factory", "--count", "2", "--seed", "1", "--out",
                       str(tmp_path / "g"))  # the preset's own budget reaches every sensor
    assert code == 0 and "note:" not in err
    assert run_cli(capsys, "validate", str(ROOT / "instances" / "dock.json"))[:2] == (0, "ok\n")
