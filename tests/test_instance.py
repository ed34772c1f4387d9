"""Every rule of MODEL.md section 1, each with a failing example, and the JSON round trip."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import voiopt
from voiopt.core.instance import from_dict, load, loads, save
from voiopt.errors import InstanceError

GOOD = {
    "name": "x",
    "area": {"width": 5, "height": 4},
    "step": 1.0,
    "horizon": 6,
    "start": [1, 2],
    "channel": {"g0_db": -50.0, "bandwidth_hz": 2e6, "noise_dbm_per_hz": -110.0, "d_th": 1.0},
    "sensors": [
        {"position": [1.3, 2.7], "rho": 0.7, "power_w": 1.0, "initial_aoi": 2, "initial_distance": 0.5},
        {"position": [4.0, 0.0], "rho": 0.2},
    ],
}


def with_change(path, value):
    d = copy.deepcopy(GOOD)
    *parents, last = path
    target = d
    for key in parents:
        target = target[key]
    if value is DELETE:
        del target[last]
    else:
        target[last] = value
    return d


DELETE = object()

BAD = [
    (("area", "width"), 0, "area.width: must be > 0, got 0"),
    (("area", "height"), -1.5, "area.height: must be > 0, got -1.5"),
    (("area", "width"), float("nan"), "area.width: must be finite, got NaN"),
    (("area", "width"), "5", 'area.width: must be a number, got "5"'),
    (("area", "depth"), 3, "area.depth: unknown field"),
    (("area",), DELETE, "area: is required"),
    (("step",), 0, "step: must be > 0, got 0"),
    (("step",), float("inf"), "step: must be finite, got Infinity"),
    (("horizon",), 0, "horizon: must be an integer >= 1, got 0"),
    (("horizon",), 2.5, "horizon: must be an integer, got 2.5"),
    (("horizon",), True, "horizon: must be an integer, got true"),
    (("horizon",), DELETE, "horizon: is required"),
    (("start",), [0.5, 1], "start: must be a lattice point"),
    (("start",), [6, 1], "start: must lie in the area"),
    (("start",), [1], "start: must be a pair [x, y], got [1]"),
    (("start",), [1, None], "start[1]: must be a finite number, got null"),
    (("channel", "bandwidth_hz"), 0, "channel.bandwidth_hz: must be > 0, got 0"),
    (("channel", "d_th"), -1, "channel.d_th: must be > 0, got -1"),
    (("channel", "g0_db"), float("-inf"), "channel.g0_db: must be finite, got -Infinity"),
    (("channel", "noise_dbm_per_hz"), None, "channel.noise_dbm_per_hz: must be a number, got null"),
    (("channel", "gain"), 1, "channel.gain: unknown field"),
    (("sensors",), [], "sensors: must be a non-empty list, got []"),
    (("sensors", 0, "position"), [5.5, 1], "sensors[0].position: must lie in the area"),
    (("sensors", 0, "position"), [1, -0.1], "sensors[0].position: must lie in the area"),
    (("sensors", 0, "rho"), 1.0, "sensors[0].rho: must be in (0, 1), got 1.0"),
    (("sensors", 1, "rho"), 0, "sensors[1].rho: must be in (0, 1), got 0"),
    (("sensors", 1, "rho"), DELETE, "sensors[1].rho: is required"),
    (("sensors", 0, "power_w"), 0, "sensors[0].power_w: must be > 0, got 0"),
    (("sensors", 0, "initial_aoi"), 0, "sensors[0].initial_aoi: must be an integer >= 1, got 0"),
    (("sensors", 0, "initial_aoi"), 1.5, "sensors[0].initial_aoi: must be an integer, got 1.5"),
    (("sensors", 0, "initial_distance"), -0.1, "sensors[0].initial_distance: must be >= 0, got -0.1"),
    (("sensors", 0, "colour"), "red", "sensors[0].colour: unknown field"),
    (("sensors", 1), 3, "sensors[1]: must be an object, got 3"),
    (("extra",), 1, "extra: unknown field"),
]


@pytest.mark.parametrize("path,value,message", BAD, ids=[m.split(":")[0] + "-" + str(i) for i, (_, _, m) in enumerate(BAD)])
def test_every_rule_has_a_clear_message(path, value, message):
    with pytest.raises(InstanceError) as e:
        from_dict(with_change(path, value))
    assert str(e.value).startswith(message), str(e.value)
    assert "\n" not in str(e.value)


def test_defaults_are_applied():
    inst = from_dict(GOOD)
    s = inst.sensors[1]
    assert (s.power_w, s.initial_aoi) == (1.0, 1)
    assert inst.initial_distance(1) == inst.channel.d_th == 1.0
    assert inst.initial_distance(0) == 0.5
    minimal = {"area": {"width": 2, "height": 2}, "horizon": 1, "start": [0, 0], "sensors": [{"position": [1, 1], "rho": 0.5}]}
    inst = from_dict(minimal)
    assert inst.step == 1.0 and inst.channel == voiopt.Channel()


def test_all_violations_are_collected():
    d = with_change(("sensors", 0, "rho"), 2.0)
    d["horizon"] = 0
    with pytest.raises(InstanceError) as e:
        from_dict(d)
    assert len(e.value.all_errors) == 2
    assert "(and 1 more)" in str(e.value)


def test_invalid_json_names_file_and_line(tmp_path):
    p = tmp_path / "broken.json"
    p.write_text('{\n  "horizon": 3,\n  "area": {\n}}}\n')
    with pytest.raises(InstanceError, match=r"broken\.json: invalid JSON: .* at line 4, column 3"):
        load(p)


def test_nan_literal_in_file_is_rejected(tmp_path):
    p = tmp_path / "nan.json"
    p.write_text(json.dumps(GOOD).replace('"rho": 0.2', '"rho": NaN'))
    with pytest.raises(InstanceError, match="NaN is not allowed"):
        load(p)
    with pytest.raises(InstanceError, match="Infinity is not allowed"):
        loads(json.dumps(GOOD).replace('"rho": 0.2', '"rho": Infinity'))


def test_missing_file(tmp_path):
    with pytest.raises(InstanceError, match="no such file"):
        load(tmp_path / "nope.json")


@st.composite
def instances(draw):
    width = draw(st.floats(0.5, 8, allow_nan=False))
    height = draw(st.floats(0.5, 8, allow_nan=False))
    step = draw(st.sampled_from([0.5, 1.0, 1.5]))
    kmax, lmax = int(width / step), int(height / step)
    n = draw(st.integers(1, 4))
    sensors = [
        {
            "position": [draw(st.floats(0, width)), draw(st.floats(0, height))],
            "rho": draw(st.floats(1e-6, 1 - 1e-9)),
            "power_w": draw(st.floats(1e-4, 10)),
            "initial_aoi": draw(st.integers(1, 50)),
            "initial_distance": draw(st.floats(0, 5)),
        }
        for _ in range(n)
    ]
    return {
        "name": "h",
        "area": {"width": width, "height": height},
        "step": step,
        "horizon": draw(st.integers(1, 40)),
        "start": [draw(st.integers(0, kmax)) * step, draw(st.integers(0, lmax)) * step],
        "channel": {"g0_db": -50.0, "bandwidth_hz": 2e6, "noise_dbm_per_hz": -110.0, "d_th": draw(st.floats(0.1, 3))},
        "sensors": sensors,
    }


@settings(max_examples=60, deadline=None)
@given(instances())
def test_round_trip_is_lossless(tmp_path_factory, d):
    inst = from_dict(d)
    p = tmp_path_factory.mktemp("rt") / "i.json"
    save(inst, p)
    assert load(p) == inst
    assert from_dict(json.loads(json.dumps(inst.to_dict()))) == inst


@settings(max_examples=60, deadline=None)
@given(instances(), st.sampled_from(["rho", "power_w", "initial_aoi"]), st.sampled_from([0, -1, float("nan"), "x", None]))
def test_any_broken_sensor_field_is_named(d, key, value):
    d["sensors"][-1][key] = value
    with pytest.raises(InstanceError) as e:
        from_dict(d)
    assert f"sensors[{len(d['sensors']) - 1}].{key}:" in str(e.value)


def test_shipped_case_study_matches_the_generator(case_study):
    assert case_study == voiopt.case_study()
    assert case_study.n_sensors == 3 and case_study.horizon == 10
    assert [s.rho for s in case_study.sensors] == [0.7, 0.6, 0.5]
    assert [s.initial_aoi for s in case_study.sensors] == [2, 4, 4]


SCHEMA = json.loads((Path(__file__).parent.parent / "docs" / "instance.schema.json").read_text())


def test_published_schema_accepts_valid_instances(case_study):
    import jsonschema

    jsonschema.validate(case_study.to_dict(), SCHEMA)
    jsonschema.validate(GOOD, SCHEMA)
    for inst in voiopt.generate_set(5, seed=2):
        jsonschema.validate(inst.to_dict(), SCHEMA)


@pytest.mark.parametrize("path,value,message", [b for b in BAD if "lattice point" not in b[2] and "lie in the area" not in b[2] and not isinstance(b[1], float)])
def test_published_schema_rejects_what_the_loader_rejects(path, value, message):
    import jsonschema

    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(with_change(path, value), SCHEMA)
