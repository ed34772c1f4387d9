"""voiopt.Policy as a user meets it: act on a documented observation, refuse a malformed one
in one message naming the field and value, show itself, and travel with its result."""

from __future__ import annotations

import json

import pytest
from oracles.expectimax import tiny

import voiopt
from voiopt.core.instance import from_dict
from voiopt.core.policy_value import exact_value
from voiopt.errors import VoioptError


@pytest.fixture(scope="module")
def best():
    inst = from_dict(tiny(2, 3, 5, {"model": "bernoulli", "success": 0.5}) | {"max_moves": 3})
    return voiopt.solve(inst, "policy-dp", "mean-min-voi")


@pytest.mark.parametrize("field,value,words", [
    ("aoi", [0, 1, 1], "observation.aoi[0]: must be an integer >= 1, got 0"),
    ("aoi", [1, 1, "x"], 'observation.aoi[2]: must be an integer >= 1, got "x"'),
    ("aoi", [1.5, 1, 1], "observation.aoi[0]: must be an integer >= 1, got 1.5"),
    ("aoi", [True, 1, 1], "observation.aoi[0]: must be an integer >= 1, got true"),
    ("distance", [1, 1, -1], "observation.distance[2]: must be a finite number >= 0, got -1"),
    ("distance", [1, float("nan"), 1], "observation.distance[1]: must be a finite number >= 0, got NaN"),
    ("distance", [1, "far", 1], 'observation.distance[1]: must be a finite number >= 0, got "far"'),
    ("moves_used", -1, "observation.moves_used: must be an integer from 0 to 3, got -1"),
    ("moves_used", 4, "observation.moves_used: must be an integer from 0 to 3, got 4"),
    ("slot", 5, "observation.slot: must be an integer from 0 to 4, got 5"),
])
def test_a_malformed_observation_is_refused_naming_the_field_and_value(best, field, value, words):
    policy = best.policy
    good = policy.observation(0, policy.steps.start_state())
    assert policy.act(good) == policy.act(dict(good))  # the documented form acts
    with pytest.raises(VoioptError) as e:
        policy.act(good | {field: value})
    assert str(e.value) == words


def test_whole_floats_are_taken_as_json_gives_them(best):
    policy = best.policy
    good = policy.observation(0, policy.steps.start_state())
    assert policy.act(good | {"aoi": [float(a) for a in good["aoi"]]}) == policy.act(good)


def test_a_policy_shows_what_it_is(best):
    assert repr(best.policy) == (f"<Policy: a table of {len(best.policy.table)} states, policy-dp, mean-min-voi, "
                                 "instance 'tiny2'>")


def test_result_save_keeps_the_policy_beside_it(best, tmp_path):
    """A policy's result saved from Python keeps its policy (RESULT.policy.json), named in the
    result; loaded again, it has the result's exact value."""
    path = tmp_path / "r.json"
    best.save(path)
    saved = json.loads(path.read_text())
    assert saved["solver"]["policy_file"] == "r.policy.json"
    loaded = voiopt.Policy.load(tmp_path / "r.policy.json")
    assert exact_value(loaded, "mean-min-voi") == pytest.approx(best.value, rel=1e-12)
