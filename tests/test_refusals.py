"""Inputs that make no sense are refused in one line, before any work; a sensible one that
looks like a mistake is a one-line warning; a byte order mark is no mistake (issue 47, item 5);
and validate is honest about fleets (item 4)."""

from __future__ import annotations

import json
import warnings

import pytest
from conftest import run_cli
from test_cli import one_line_error

import voiopt
from voiopt.cli import validate as cli_validate
from voiopt.errors import InstanceWarning, OptionError
from voiopt.grid import joint
from voiopt.mdp import robot as mdp
from voiopt.networks import fields
from voiopt.networks.generate import case_study


@pytest.mark.parametrize("penalty, message", [
    (-1.0, "penalty: must be >= 0"),
    (1e308, r"so that an episode's return stays finite, got 1e\+308"),
])
def test_a_penalty_that_makes_no_sense_is_refused(penalty, message):
    for method in ("qlearning", "aoi-qlearning"):
        with pytest.raises(OptionError, match=message):
            voiopt.solve(case_study(), method=method, episodes=10, penalty=penalty)
    with pytest.raises(OptionError, match=message):
        mdp.build(case_study(), penalty=penalty)
    mdp.check_penalty(1e300 / case_study().horizon)  # the largest that keeps an episode's return finite


def test_quiet_and_verbose_together_are_refused(capsys, tmp_path):
    code, out, err = run_cli(capsys, "solve", "instances/case-study.json", "--quiet", "--verbose")
    assert code == 2 and out == "" and "--quiet, --verbose: give one" in one_line_error(err)


@pytest.mark.parametrize("argv, message", [
    (["--sensors", "20000"], "sensors: must be at most 10000"),
    (["--sensors", "5000", "--width", "30", "--height", "30"], "sensor-lattice point pairs"),
    (["--horizon", "2000000"], "horizon: must be at most 1000000"),
    (["--horizon", "1000", "--initial-aoi", "1", "1999999"], "initial-aoi: its largest, 1999999"),
    (["--preset", "factory", "--horizon", "2000000"], "horizon: must be at most 1000000"),
])
def test_generate_refuses_sizes_before_drawing(capsys, monkeypatch, argv, message):
    def drawn(*a, **k):
        raise AssertionError("drew a network that would be refused")
    monkeypatch.setattr(fields, "seeded", drawn)
    code, out, err = run_cli(capsys, "generate", *argv)
    assert code == 2 and out == "" and message in one_line_error(err)


def test_a_byte_order_mark_is_accepted(tmp_path, capsys):
    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps(case_study().to_dict()).encode())
    assert voiopt.load(path).to_dict() == case_study().to_dict()
    code, out, _ = run_cli(capsys, "validate", str(path))
    assert code == 0 and out.strip() == "ok"


def test_a_truncated_file_gets_a_whole_phrase(tmp_path, capsys):
    path = tmp_path / "cut.json"
    path.write_text('{"name": "case-stu')
    code, _, err = run_cli(capsys, "validate", str(path))
    assert code == 2
    assert one_line_error(err).endswith("invalid JSON: Unterminated string starting at line 1, column 10")


def test_a_duplicated_sensor_is_a_one_line_warning(tmp_path, capsys):
    d = case_study().to_dict()
    d["sensors"].append(dict(d["sensors"][1]))
    path = tmp_path / "twice.json"
    path.write_text(json.dumps(d))
    code, out, err = run_cli(capsys, "validate", str(path))
    assert code == 0 and out.strip() == "ok"
    assert err.strip() == f"voiopt: warning: {path}: sensors[3]: same position and parameters as sensors[1] " \
                          "(both are kept; is it a copy?)"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        voiopt.load("instances/case-study.json")  # no warning otherwise
    with pytest.warns(InstanceWarning, match=r"sensors\[3\]: same position"):
        voiopt.core.instance.from_dict(d)


# ------------------------------------------------------------------------------ fleets


def _fleet(path, width, robots, horizon, blocked=()):
    d = {"name": path.stem, "area": {"width": float(width), "height": float(width if not blocked else 1)},
         "horizon": horizon, "robots": robots, "blocked": list(blocked),
         "sensors": [{"position": [width / 2, 0.5], "rho": 0.5}]}
    path.write_text(json.dumps(d))
    return path


def _corridor(tmp_path):
    """Three robots in a corridor 40 points long: the two at its ends cannot swap. The joint
    table of three (80**3 points x 60 slots) is too large to build; validate said ok."""
    robots = [{"start": [0.0, 0.0], "end": [39.0, 0.0]}, {"start": [39.0, 0.0], "end": [0.0, 0.0]},
              {"start": [20.0, 0.0], "end": [20.0, 0.0]}]
    return _fleet(tmp_path / "corridor.json", 39, robots, 60, [[x, 1.0] for x in range(40)])


def test_validate_rejects_three_robots_that_cannot_swap_in_a_corridor(tmp_path, capsys):
    code, out, err = run_cli(capsys, "validate", str(_corridor(tmp_path)))
    assert code == 2 and out == "" and "robots: no legal joint plan" in one_line_error(err)


def test_validate_says_how_it_decided_an_open_fleet_or_that_it_could_not(tmp_path, capsys, monkeypatch):
    robots = [{"start": [0.0, 0.0], "end": [20.0, 20.0]}, {"start": [20.0, 20.0], "end": [0.0, 0.0]},
              {"start": [10.0, 0.0], "end": [10.0, 20.0]}]
    path = _fleet(tmp_path / "open.json", 20, robots, 100)
    code, out, _ = run_cli(capsys, "validate", str(path))
    assert code == 0 and out.startswith("ok (3 robots; greedy found a legal joint plan in ")
    # without the pairs' proof, the corridor is undecided: the walker gives up, and validate says so
    monkeypatch.setattr(joint, "pairs_possible", lambda *a: None)
    code, out, _ = run_cli(capsys, "validate", str(_corridor(tmp_path)))
    assert code == cli_validate.UNDECIDED == 3 and out.startswith("skipped: the joint check of 3 robots"), out
    assert "undecided" in out and len(out.strip().splitlines()) == 1
