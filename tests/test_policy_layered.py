"""The layered expectimax over packed states (voiopt/solvers/policy/layered.py) is the plain
expectimax (expectimax.py) bit for bit: the same value (floats equal), the same number of
states, and the same action in every state its optimal policy reaches, listed in the same
order; on random tiny instances of every kind (bernoulli and rayleigh links, a sensor's own
success, max_moves, end, both averaged objectives, success tables with 0/1 entries as the
information relaxation makes them). Its chunks change nothing, its stop rule is looked at
inside a layer, and states that do not pack go to the plain expectimax."""

from __future__ import annotations

import numpy as np
import pytest
from oracles.expectimax import tiny

import voiopt
from voiopt.core.instance import from_dict
from voiopt.runtime.stop import Stop, Stopped
from voiopt.solvers.policy import layered, packed
from voiopt.solvers.policy.expectimax import Expectimax
from voiopt.solvers.policy.layered import Layered, exact_search
from voiopt.solvers.policy.relaxation import availability

OBJECTIVES = ("mean-min-voi", "mean-max-aoi")


def random_case(seed: int):
    """A tiny instance of a kind drawn from ``seed``, and a success table (None: the links')."""
    rng = np.random.default_rng(seed)
    n, T = int(rng.integers(1, 4)), int(rng.integers(2, 7))
    if rng.random() < 0.5:
        links = {"model": "bernoulli", "success": float(rng.choice([0.3, 0.5, 0.85, 1.0]))}
    else:
        links = {"model": "rayleigh", "snr_threshold_db": float(rng.uniform(24.0, 30.0))}
    d = tiny(seed, n, T, links)
    for s in d["sensors"]:
        if rng.random() < 0.3:
            s["success"] = float(rng.choice([0.2, 0.6, 1.0]))
    if rng.random() < 0.4:
        d["max_moves"] = int(rng.integers(0, T))
    if rng.random() < 0.4:  # an end within reach of the start, in the slots and the budget
        reach = min(T - 1, d.get("max_moves", T))
        x, y = d["start"]
        while reach > 0 and rng.random() < 0.7:
            x, y = (min(2, x + 1), y) if rng.random() < 0.5 else (x, max(0, y - 1))
            reach -= 1
        d["end"] = [x, y]
    inst = from_dict(d)
    kind = seed % 3  # the links' table; a 0/1 table (a scenario's availability); a mixed one
    if kind == 0:
        return inst, None
    u = np.random.default_rng(seed + 1).random((T, n))
    succ = availability(inst, u)
    if kind == 2:
        succ = np.where(np.random.default_rng(seed + 2).random(succ.shape) < 0.5, succ, 0.45)
    return inst, succ


def same(inst, objective, succ=None):
    plain, fast = Expectimax(inst, objective, succ), Layered(inst, objective, succ)
    value = fast.solve()
    assert value == plain.solve()  # the same float, not merely close
    assert fast.states == plain.states
    assert fast.on_policy() == plain.on_policy()
    return fast


@pytest.mark.parametrize("objective", OBJECTIVES)
def test_layered_is_the_plain_expectimax_bit_for_bit(objective):
    kinds = set()
    for seed in range(150):
        inst, succ = random_case(seed)
        same(inst, objective, succ)
        kinds.add((inst.links.model, inst.max_moves is not None, inst.end is not None, seed % 3))
    assert len(kinds) >= 20  # nearly every kind of links, rule and table met


@pytest.mark.parametrize("objective", OBJECTIVES)
def test_four_sensors_and_longer_horizons(objective):
    for seed, extra in ((101, {}), (102, {"max_moves": 4}), (103, {"end": [1, 1]})):
        d = tiny(seed, 4, 7, {"model": "bernoulli", "success": 0.6}, **extra)
        d["sensors"][1]["success"] = 0.9
        same(from_dict(d), objective)


def test_chunks_change_nothing_and_the_stop_rule_is_looked_at_inside_a_layer(monkeypatch):
    inst = from_dict(tiny(7, 3, 6, {"model": "bernoulli", "success": 0.5}, max_moves=3))
    whole = Layered(inst, "mean-min-voi")
    value, rows = whole.solve(), whole.on_policy()
    monkeypatch.setattr(layered, "CHUNK_CHILDREN", 16)
    monkeypatch.setattr(layered, "CHUNK_STATES", 3)
    ticks = []
    small = Layered(inst, "mean-min-voi", tick=ticks.append)
    assert small.solve() == value and small.on_policy() == rows
    assert len(ticks) > 4 * inst.horizon  # several looks a layer, forward and back
    assert max(ticks) == small.states == whole.states


@pytest.mark.parametrize(("limits", "reason"), [(dict(time_limit=0.0), "time_limit"),
                                                (dict(memory_limit=1e-7), "memory_limit")])
def test_the_stop_rule_stops_it(limits, reason):
    stop = Stop(**limits)
    search = Layered(from_dict(tiny(2, 3, 5, {"model": "bernoulli", "success": 0.5})), "mean-max-aoi", stop=stop)
    with pytest.raises(Stopped):
        search.solve()
    assert stop.reason == reason


def test_states_that_do_not_pack_go_to_the_plain_expectimax(monkeypatch):
    inst = from_dict(tiny(3, 2, 4, {"model": "bernoulli", "success": 0.5}))
    fast = exact_search(inst, "mean-min-voi")
    assert isinstance(fast, Layered)
    monkeypatch.setattr(packed, "KEY_BITS", 5)
    search = exact_search(inst, "mean-min-voi")
    assert isinstance(search, Expectimax)
    assert search.solve() == fast.solve()
    assert voiopt.solve(inst, "policy-dp", "mean-min-voi").solver["search"].startswith("plain")
    with pytest.raises(ValueError, match="bits, more than a key's 5"):
        Layered(inst, "mean-min-voi").solve()


def test_a_key_holds_its_state():
    inst = from_dict(tiny(5, 3, 5, {"model": "bernoulli", "success": 0.7}, max_moves=2))
    search = Layered(inst, "mean-min-voi")
    search.solve()
    states = [s for _, s, _ in search.on_policy()]
    keys = [search.packing.encode(s) for s in states]
    assert search.packing.decode(np.array(keys)) == states
    assert len(set(keys)) == len(set(states))
