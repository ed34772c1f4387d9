"""The JSON layout of written files: ``dumps_json`` is json.dumps(indent=2) to the character,
however it lays out long lists of numbers."""

from __future__ import annotations

import json
from unittest import mock

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import voiopt
from voiopt.runtime import files

SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-(2**70), 2**70), st.floats(allow_nan=False, allow_infinity=False))
LEAVES = st.one_of(SCALARS, st.text(alphabet=st.sampled_from('ab,[]{}":\\\n é'), max_size=6))
VALUES = st.recursive(
    LEAVES,
    lambda inner: st.one_of(
        st.lists(inner, max_size=6),
        st.lists(SCALARS, max_size=8),
        st.lists(st.lists(SCALARS, min_size=1, max_size=3), max_size=8),  # pairs, and lists of other lengths
        st.lists(st.lists(SCALARS, max_size=2), max_size=4),  # empty ones among them
        st.tuples(SCALARS, SCALARS),
        st.dictionaries(st.text(max_size=4), inner, max_size=4),
    ),
    max_leaves=40,
)


@settings(max_examples=400, deadline=None)
@given(VALUES)
def test_the_layout_is_jsons_own(obj):
    """With the length from which lists are laid out by hand lowered to 2, every list of
    scalars and of lists of scalars on the way goes through that path, at any depth."""
    with mock.patch.object(files, "LONG_LIST", 2):
        assert files.dumps_json(obj) == json.dumps(obj, indent=2, allow_nan=False)
    assert files.dumps_json(obj) == json.dumps(obj, indent=2, allow_nan=False)


def test_a_nan_in_a_long_list_is_refused_as_json_refuses_it():
    with pytest.raises(ValueError):
        files.dumps_json({"x": [1.0] * 300 + [float("nan")]})


def test_a_long_plans_result_reads_back_as_written(tmp_path):
    """A result of T = 5000 slots written with the layout reads back as the same result."""
    inst = voiopt.generate(3, 5000, seed=2)
    r = voiopt.solve(inst, "shortest-path")
    r.save(tmp_path / "r.json")
    text = (tmp_path / "r.json").read_text()
    assert text == json.dumps(r.to_dict(), indent=2, allow_nan=False) + "\n"
    assert voiopt.load_result(tmp_path / "r.json").to_dict() == r.to_dict()


def test_a_nan_is_named_and_deep_or_circular_objects_fare_as_in_json():
    """After review: a NaN in a long list is refused with json's own message, which names it;
    nesting deeper than dumps_json looks and a circular reference are json's to handle."""
    with pytest.raises(ValueError, match="not JSON compliant: nan"):
        files.dumps_json({"positions": [[0, 0]] * 300 + [[float("nan"), 0]]})
    deep: list = [1] * 300
    for _ in range(900):
        deep = [deep]
    assert files.dumps_json(deep) == json.dumps(deep, indent=2)
    loop: list = [1] * 300
    loop.append(loop)
    with pytest.raises(ValueError, match="Circular reference"):
        files.dumps_json({"a": loop})
