"""Fuzz the instance loader with hostile JSON: every document gives a valid Instance or a
VoioptError, never another exception, and loading it (and building the lattice of a valid
one) takes under 1 s and 100 MB of Python allocations (tracemalloc peak, numpy included).

(a) random JSON documents (keys partly the real field names, numbers huge, tiny, NaN and
    infinite), plus raw hostile texts (deep nesting, integer literals beyond Python's
    4300-digit limit, unterminated strings, lone surrogates);
(b) mutations of a valid instance: a field at any path replaced by a random or an
    interesting value, a field deleted, an unknown field added, the sensors multiplied.

Deterministic (derandomize, no example database), so CI sees the same examples every run.
"""

from __future__ import annotations

import copy
import gc
import json
import math
import os
import time
import tracemalloc

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from voiopt.core.instance import Instance, from_dict, loads
from voiopt.errors import VoioptError
from voiopt.grid import lattice

MAX_SECONDS = 1.0
MAX_BYTES = 100 * 2**20
# FUZZ_EXAMPLES=5000 for a longer hunt; the default keeps this file well under 30 s
EXAMPLES = int(os.environ.get("FUZZ_EXAMPLES", "250"))
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

GOOD = {
    "name": "fuzz",
    "area": {"width": 5, "height": 4},
    "step": 1.0,
    "horizon": 12,
    "start": [1, 2],
    "channel": {"g0_db": -50.0, "bandwidth_hz": 2e6, "noise_dbm_per_hz": -110.0, "d_th": 1.0},
    "sensors": [
        {"position": [1.3, 2.7], "rho": 0.7, "power_w": 1.0, "initial_aoi": 2, "initial_distance": 0.5},
        {"position": [4.0, 0.0], "rho": 0.2},
    ],
}
FIELDS = ["name", "area", "width", "height", "step", "horizon", "start", "channel", "g0_db", "bandwidth_hz",
          "noise_dbm_per_hz", "d_th", "sensors", "position", "rho", "power_w", "initial_aoi", "initial_distance"]
HUGE_LITERAL = "\u0000huge-int"  # replaced in the text by an integer literal of 5000 digits

INTERESTING = st.sampled_from([
    0, 1, -1, 2, 0.5, 1e-5, 1e-300, 5e-324, 1e300, 1e308, -1e308, 1.7976931348623157e308,
    10**6, 10**6 + 1, 10**9, 2**31, 2**63, 2**70, 10**30, 10**400, -10**400,
    math.nan, math.inf, -math.inf, True, None, "", "5", [], {}, [0, 0], [1e308, 1e308], HUGE_LITERAL,
]).map(copy.deepcopy)  # a fresh [] or {} each time: mutations must not change the strategy
SCALARS = st.one_of(
    st.none(), st.booleans(), st.integers(), st.integers(-(10**420), 10**420), st.floats(),
    st.text(max_size=8), INTERESTING,
)
KEYS = st.one_of(st.sampled_from(FIELDS), st.text(max_size=6))
JSON = st.recursive(
    SCALARS,
    lambda inner: st.lists(inner, max_size=5) | st.dictionaries(KEYS, inner, max_size=6),
    max_leaves=25,
)
DOCUMENTS = st.one_of(JSON, st.dictionaries(st.sampled_from(FIELDS), JSON, max_size=8))


def dump(doc) -> str:
    text = json.dumps(doc, allow_nan=True)  # NaN and Infinity tokens: the loader must refuse them
    return text.replace(json.dumps(HUGE_LITERAL), "9" * 5000)


def hostile_texts() -> st.SearchStrategy[str]:
    good = json.dumps(GOOD)
    return st.one_of(
        st.integers(0, 5000).map(lambda k: "[" * k + "]" * k),
        st.integers(0, 5000).map(lambda k: '{"area": ' + "[" * k + "1" + "]" * k + "}"),
        st.integers(1, 6000).map(lambda k: good.replace('"horizon": 12', '"horizon": ' + "9" * k)),
        st.sampled_from(['"rho": 1e400', '"rho": -1e99999', '"rho": 0.' + "0" * 5000 + "1"]).map(
            lambda s: good.replace('"rho": 0.2', s)),
        st.sampled_from(['{"name": "\\ud800"', '{"a\\nb": 1}', '"\\', '["' + "\\" * 1000, "[" * 200 + '"']),
        st.text(max_size=30),
    )


def _mutations(draw, doc):
    """One mutation of ``doc`` in place: replace, delete, add a field, or repeat the sensors."""
    paths, stack = [], [((), doc)]
    while stack:
        path, node = stack.pop()
        paths.append(path)
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        stack += [((*path, k), v) for k, v in items]
    path = draw(st.sampled_from(paths))
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    action = draw(st.sampled_from(["replace", "replace", "interesting", "interesting", "delete", "add", "repeat"]))
    if action == "repeat" and isinstance(doc.get("sensors"), list):  # the caps: test_bounds_at_the_caps
        doc["sensors"] = [copy.deepcopy(x) for x in doc["sensors"][:4] * draw(st.sampled_from([2, 50]))]
    elif action in ("add", "repeat"):
        target = doc if not isinstance(parent, dict) else parent
        target[draw(KEYS)] = draw(JSON)
    elif not path:
        return
    elif action == "delete":
        del parent[path[-1]]
    else:
        parent[path[-1]] = draw(INTERESTING if action == "interesting" else JSON)


@st.composite
def mutants(draw):
    doc = copy.deepcopy(GOOD)
    for _ in range(draw(st.integers(1, 3))):
        _mutations(draw, doc)
    return doc


def _load_and_build(load):
    """``load()`` and, for a valid instance, the lattice build; returns the instance or None."""
    lattice.build.cache_clear()
    try:
        try:
            inst = load()
        except VoioptError as e:
            assert "\n" not in str(e), str(e)
            return None
        assert isinstance(inst, Instance)
        lat = lattice.build(inst)
        assert lat.n_points <= 10**6 and lat.distance.shape == (inst.n_sensors, lat.n_points)
        unservable = [i for i in range(inst.n_sensors) if not lat.in_range[i].any()]
        assert lattice.unservable_sensors(inst) == unservable  # the fast path agrees with build
        return inst
    finally:
        lattice.build.cache_clear()


def _bounded(load):
    """Check the bounds of the module docstring: the time untraced (tracemalloc slows small
    allocations tenfold), best of three runs so that a busy shared machine does not fail it,
    then the peak of Python allocations in a traced run."""
    seconds = math.inf
    for attempt in range(3):
        if attempt:
            gc.collect()  # not every time: a full collection costs more than most examples
        start = time.perf_counter()
        inst = _load_and_build(load)
        seconds = min(seconds, time.perf_counter() - start)
        if seconds < MAX_SECONDS:
            break
    assert seconds < MAX_SECONDS, f"{seconds:.2f} s"
    tracemalloc.start()
    try:
        _load_and_build(load)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < MAX_BYTES, f"{peak / 2**20:.0f} MB"
    return inst


@SETTINGS
@given(DOCUMENTS)
def test_random_documents_load_or_fail_cleanly(doc):
    text = dump(doc)
    _bounded(lambda: loads(text))
    _bounded(lambda: from_dict(doc))  # the Python API: NaN and inf reach the validators


@SETTINGS
@given(hostile_texts())
def test_hostile_texts_load_or_fail_cleanly(text):
    _bounded(lambda: loads(text))


@pytest.mark.filterwarnings("ignore::hypothesis.errors.HypothesisWarning")  # the repr of 10**4 sensors
@SETTINGS
@given(mutants())
def test_mutated_instances_load_or_fail_cleanly(doc):
    text = dump(doc)
    a = _bounded(lambda: loads(text))
    b = _bounded(lambda: from_dict(doc))
    if a is not None and b is not None:
        assert a == b  # the file and the API agree


def _at(width, height, n_sensors):
    doc = copy.deepcopy(GOOD)
    doc["area"] = {"width": width, "height": height}
    doc["sensors"] = [{"position": [1.5, 0.5 + i % 3], "rho": 0.5} for i in range(n_sensors)]
    return doc


@pytest.mark.parametrize("doc,valid", [
    (_at(5, 4, 10**4), True),  # the cap on sensors
    (_at(5, 4, 10**4 + 1), False),
    (_at(999, 999, 2), True),  # 10**6 lattice points and 2 * 10**6 sensor-point pairs: the largest lattice
    (_at(1000, 999, 2), False),
    (_at(999, 999, 3), False),
], ids=["sensors-cap", "sensors-over", "lattice-cap", "lattice-over", "pairs-over"])
def test_bounds_at_the_caps(doc, valid):
    """The largest valid instances load and build within the bounds; one more is refused."""
    text = json.dumps(doc)
    inst = _bounded(lambda: loads(text))
    assert (inst is not None) == valid
