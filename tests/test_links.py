"""Lossy links of MODEL.md section 11: the ``links`` field's loader, its round trip and schema,
the success probabilities (voiopt.core.links) against the formula written out, and the rule
that an instance whose every probability is 1 is not lossy."""

from __future__ import annotations

import copy
import json
import math
import subprocess
import sys
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from voiopt.core.instance import Links, from_dict
from voiopt.core.links import is_lossy, success_probability, success_table
from voiopt.errors import InstanceError
from voiopt.grid import lattice

SCHEMA = json.loads((Path(__file__).parent.parent / "docs" / "instance.schema.json").read_text())
VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)  # built once: the property tests validate hundreds
GOOD = {
    "name": "lossy",
    "area": {"width": 3, "height": 2},
    "horizon": 6,
    "start": [0, 0],
    "sensors": [
        {"position": [1.0, 1.0], "rho": 0.7, "initial_aoi": 2},
        {"position": [2.5, 0.4], "rho": 0.4, "power_w": 0.5},
    ],
}
SETTINGS = settings(max_examples=100, deadline=None, derandomize=True, database=None)


def with_links(links, **sensor0):
    d = copy.deepcopy(GOOD)
    d["links"] = links
    d["sensors"][0].update(sensor0)
    return d


def rayleigh_by_hand(inst, i, d):
    """p_i(d) = exp(-gamma B N0 d^2 / (P_i g0)), MODEL.md section 11, written out."""
    ch, s = inst.channel, inst.sensors[i]
    gamma = 10 ** (inst.links.snr_threshold_db / 10)
    bn0 = ch.bandwidth_hz * 10 ** (ch.noise_dbm_per_hz / 10) / 1000
    return math.exp(-gamma * bn0 * d * d / (s.power_w * 10 ** (ch.g0_db / 10)))


BAD = [
    ({"model": "gilbert"}, "links.model", "gilbert"),
    ({"model": 3}, "links.model", "3"),
    ({"success": 0.5}, "links.model", "is required"),
    ({"model": "bernoulli"}, "links.success", "is required"),
    ({"model": "bernoulli", "success": 0}, "links.success", "(0, 1]"),
    ({"model": "bernoulli", "success": 1.5}, "links.success", "1.5"),
    ({"model": "bernoulli", "success": -0.2}, "links.success", "-0.2"),
    ({"model": "bernoulli", "success": True}, "links.success", "true"),
    ({"model": "bernoulli", "success": "0.5"}, "links.success", '"0.5"'),
    ({"model": "bernoulli", "success": math.nan}, "links.success", "NaN"),
    ({"model": "bernoulli", "success": 0.5, "snr_threshold_db": 3}, "links.snr_threshold_db", "bernoulli"),
    ({"model": "rayleigh"}, "links.snr_threshold_db", "is required"),
    ({"model": "rayleigh", "snr_threshold_db": math.inf}, "links.snr_threshold_db", "Infinity"),
    ({"model": "rayleigh", "snr_threshold_db": -math.inf}, "links.snr_threshold_db", "-Infinity"),
    ({"model": "rayleigh", "snr_threshold_db": math.nan}, "links.snr_threshold_db", "NaN"),
    ({"model": "rayleigh", "snr_threshold_db": None}, "links.snr_threshold_db", "null"),
    ({"model": "rayleigh", "snr_threshold_db": 3, "success": 0.9}, "links.success", "rayleigh"),
    ({"model": "bernoulli", "success": 0.5, "loss": 0.1}, "links.loss", "unknown field"),
    ([0.5], "links", "[0.5]"),
]


@pytest.mark.parametrize("links,path,shown", BAD)
def test_bad_links_are_one_line_naming_the_field_and_value(links, path, shown):
    with pytest.raises(InstanceError) as e:
        from_dict(with_links(links))
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(path + ":") and shown in msg


@pytest.mark.parametrize("value", [0, 1.01, -1, True, "1", None, math.nan, math.inf])
def test_bad_sensor_success_is_rejected(value):
    with pytest.raises(InstanceError, match=r"^sensors\[0\]\.success: "):
        from_dict(with_links({"model": "rayleigh", "snr_threshold_db": 5.0}, success=value))


def test_sensor_success_needs_links():
    d = copy.deepcopy(GOOD)
    d["sensors"][1]["success"] = 0.5
    with pytest.raises(InstanceError, match=r"^sensors\[1\]\.success: is only allowed with links.*0\.5"):
        from_dict(d)


def test_bad_links_exit_2_on_the_command_line(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(with_links({"model": "bernoulli", "success": 2})))
    run = subprocess.run([sys.executable, "-m", "voiopt", "evaluate", str(path), str(path)], capture_output=True,
                         text=True, cwd=Path(__file__).parent.parent)
    assert run.returncode == 2
    assert "links.success" in run.stderr and "Traceback" not in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1


def test_without_links_to_dict_is_unchanged():
    inst = from_dict(GOOD)
    assert inst.links is None and all(s.success is None for s in inst.sensors)
    d = inst.to_dict()
    assert "links" not in d and all("success" not in s for s in d["sensors"])
    assert not is_lossy(inst)


PROB = st.floats(min_value=0.0, max_value=1.0, exclude_min=True)
LINKS = st.one_of(
    st.builds(lambda p: {"model": "bernoulli", "success": p}, PROB),
    st.builds(lambda x: {"model": "rayleigh", "snr_threshold_db": x},
              st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6)),
)


@SETTINGS
@given(LINKS, st.one_of(st.none(), PROB), st.one_of(st.none(), PROB))
def test_valid_links_round_trip_and_match_the_schema(links, p0, p1):
    d = with_links(links)
    for s, p in zip(d["sensors"], (p0, p1), strict=True):
        if p is not None:
            s["success"] = p
    inst = from_dict(d)
    assert inst.links == Links(**links)
    assert [s.success for s in inst.sensors] == [p0, p1]
    out = inst.to_dict()
    assert out["links"] == links
    assert from_dict(out).to_dict() == out
    assert from_dict(json.loads(json.dumps(out))) == from_dict(out)
    VALIDATOR.validate(out)


@SETTINGS
@given(LINKS, st.sampled_from(["success", "snr_threshold_db", "model"]),
       st.one_of(st.floats(), st.integers(-10**6, 10**6), st.booleans(), st.text(max_size=3), st.none()))
def test_mutated_links_load_or_fail_on_the_links_field(links, key, value):
    """Any change to a valid links object either loads (and then round-trips) or is rejected
    with one line naming a links field; never another exception."""
    bad = dict(links)
    bad[key] = value
    try:
        inst = from_dict(with_links(bad))
    except InstanceError as e:
        assert str(e).startswith("links") and "\n" not in str(e)
        if not (isinstance(value, float) and not math.isfinite(value)):  # JSON has no NaN or Infinity
            assert not VALIDATOR.is_valid(with_links(bad))
        return
    assert from_dict(inst.to_dict()).to_dict() == inst.to_dict()
    p = bad.get("success")
    assert p is None or 0 < p <= 1


@SETTINGS
@given(st.floats(min_value=-60, max_value=60), st.floats(min_value=0, max_value=3))
def test_rayleigh_probability_is_the_formula(threshold_db, d):
    inst = from_dict(with_links({"model": "rayleigh", "snr_threshold_db": threshold_db}))
    for i in range(2):
        p = success_probability(inst, i, d)
        assert isinstance(p, float)
        assert p == pytest.approx(rayleigh_by_hand(inst, i, d), rel=1e-12, abs=1e-300)
        assert 0.0 <= p <= 1.0


def test_extreme_thresholds_give_probabilities_not_nan():
    hard = from_dict(with_links({"model": "rayleigh", "snr_threshold_db": 1e6}))
    easy = from_dict(with_links({"model": "rayleigh", "snr_threshold_db": -1e6}))
    d = np.array([0.0, 0.5, 1.0])
    assert success_probability(hard, 0, d).tolist() == [1.0, 0.0, 0.0]
    assert success_probability(easy, 0, d).tolist() == [1.0, 1.0, 1.0]
    assert is_lossy(hard) and not is_lossy(easy)


def test_probabilities_of_each_model_and_the_override():
    bern = from_dict(with_links({"model": "bernoulli", "success": 0.8}, success=0.3))
    assert success_probability(bern, 0, 0.7) == 0.3
    assert success_probability(bern, 1, np.array([0.1, 0.9])).tolist() == [0.8, 0.8]
    ray = from_dict(with_links({"model": "rayleigh", "snr_threshold_db": 30.0}, success=0.6))
    assert success_probability(ray, 0, 0.9) == 0.6
    assert success_probability(ray, 1, 0.9) == rayleigh_by_hand(ray, 1, 0.9)
    assert success_probability(from_dict(GOOD), 1, 0.9) == 1.0


@pytest.mark.parametrize("links", [{"model": "bernoulli", "success": 0.8},
                                   {"model": "rayleigh", "snr_threshold_db": 29.0}])
def test_success_table_is_p_in_range_and_zero_out_of_range(links):
    inst = from_dict(with_links(links))
    lat = lattice.build(inst)
    table = success_table(inst, lat)
    assert table.dtype == np.float64 and table.shape == (lat.n_points, inst.n_sensors)
    for i in range(inst.n_sensors):
        for p in range(lat.n_points):
            want = success_probability(inst, i, float(lat.distance[i, p])) if lat.in_range[i, p] else 0.0
            assert table[p, i] == want
    assert (table[lat.in_range.T] > 0).all()


def test_all_ones_is_not_lossy():
    assert not is_lossy(from_dict(with_links({"model": "bernoulli", "success": 1})))
    assert not is_lossy(from_dict(with_links({"model": "bernoulli", "success": 0.5}, success=1.0) | {
        "sensors": [{"position": [1.0, 1.0], "rho": 0.7, "success": 1}, {"position": [2.5, 0.4], "rho": 0.4, "success": 1}]}))
    assert is_lossy(from_dict(with_links({"model": "bernoulli", "success": 0.999})))
    assert is_lossy(from_dict(with_links({"model": "bernoulli", "success": 1}, success=0.5)))
    # rayleigh: p < 1 wherever a robot stands at a distance > 0 from a sensor
    assert is_lossy(from_dict(with_links({"model": "rayleigh", "snr_threshold_db": 0.0})))


def test_a_sensor_that_no_open_point_reaches_does_not_make_it_lossy():
    d = with_links({"model": "bernoulli", "success": 1})
    d["sensors"].append({"position": [2.5, 1.5], "rho": 0.5, "success": 0.5})
    d["blocked"] = [[2, 1], [3, 1], [2, 2], [3, 2]]  # every point within d_th = 1 of (2.5, 1.5)
    inst = from_dict(d)
    assert not is_lossy(inst)
    d["blocked"] = d["blocked"][1:]
    assert is_lossy(from_dict(d))
