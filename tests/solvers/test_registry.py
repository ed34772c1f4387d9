"""The registry's entries: each is a Solver whose keyword options are exactly its Options
dataclass (names and defaults), and options are checked at the edge."""

from __future__ import annotations

import dataclasses
import inspect

import pytest

import voiopt
from voiopt import objectives
from voiopt.errors import OptionError
from voiopt.solvers import METHODS, Solver, options_class, solver_function
from voiopt.solvers.options import Options


@pytest.mark.parametrize("method", sorted(METHODS))
def test_every_entry_is_a_solver_whose_keywords_are_its_options(method):
    fn, opts = solver_function(method), options_class(method)
    assert isinstance(fn, Solver)
    params = inspect.signature(fn).parameters
    assert list(params)[:2] == ["instance", "objective"]
    keywords = {k: p.default for k, p in params.items() if p.kind is p.KEYWORD_ONLY}
    assert issubclass(opts, Options) and dataclasses.is_dataclass(opts)
    assert {f.name: f.default for f in dataclasses.fields(opts)} == keywords
    assert {"progress", "time_limit", "memory_limit"} <= set(keywords)


def test_an_unknown_option_is_refused_naming_what_the_method_takes():
    inst = voiopt.generate(2, 4, width=2.0, height=2.0, seed=0)
    with pytest.raises(OptionError, match=r"^beem: not an option of method 'dp' \(it takes time_limit, memory_limit, warm_start, beam"):
        voiopt.solve(inst, "dp", beem=3)
    with pytest.raises(OptionError, match="--time-limit: must be a number of seconds > 0"):
        options_class("greedy").of("greedy", {"time_limit": -1})
    with pytest.raises(OptionError, match=r"it takes time_limit, memory_limit, seed\)$"):
        options_class("shortest-path").of("shortest-path", {"nope": 1})


def test_the_objective_travels_as_the_object():
    inst = voiopt.generate(2, 4, width=2.0, height=2.0, seed=0)
    seen = []
    real = solver_function("greedy")

    def spy(instance, objective, **options):
        seen.append(objective)
        return real(instance, objective, **options)

    import voiopt.solvers.baselines.heuristics as heuristics

    original = heuristics.greedy
    heuristics.greedy = spy
    try:
        result = voiopt.solve(inst, "greedy", "max-aoi")
    finally:
        heuristics.greedy = original
    assert seen and seen[0] is objectives.MAX_AOI and seen[0].worth is objectives.Worth.AOI
    assert result.objective == "max-aoi" and result.to_dict()["objective"] == "max-aoi"
