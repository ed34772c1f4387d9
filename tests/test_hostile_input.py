"""Huge and hostile input through the command line, as a user runs it: every bad file gets
one line on stderr naming the field (and the limit, where there is one), exit status 2, no
traceback, no hang, no huge allocation (each run is limited to 1 GB of address space).

One test per problem of the hardening issue; a ``validate`` run checks several files at
once (one line each), so the whole file needs about ten interpreter start-ups.
"""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import pytest

CASE_STUDY = Path(__file__).resolve().parent.parent / "voiopt" / "data" / "case-study.json"
PLAN = Path(__file__).resolve().parent.parent / "voiopt" / "data" / "case-study.plan.json"
GOOD = json.loads(CASE_STUDY.read_text())
GOOD_PLAN = json.loads(PLAN.read_text())


def _limit_memory() -> None:  # in the child, before exec: a huge allocation fails instead of swapping
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (2**30, 2**30))


def voiopt(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "voiopt", *args], capture_output=True, text=True, timeout=120, cwd=cwd,
        preexec_fn=_limit_memory if sys.platform.startswith("linux") else None,
    )


def changed(edit) -> dict:
    d = copy.deepcopy(GOOD)
    edit(d)
    return d


def write(folder: Path, name: str, content) -> Path:
    p = folder / f"{name}.json"
    p.write_text(content if isinstance(content, str) else json.dumps(content))
    return p


def check_validate(tmp_path: Path, cases: dict[str, tuple[object, list[str]]]) -> None:
    """``voiopt validate`` on every case at once: exit 2, and for each file exactly one line
    on stderr, starting with its path and holding every expected piece of text."""
    paths = {name: write(tmp_path, name, content) for name, (content, _) in cases.items()}
    r = voiopt("validate", *map(str, paths.values()), cwd=tmp_path)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "Traceback" not in r.stderr and r.stdout == "", r.stdout + r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == len(cases), r.stderr
    for (name, (_, expected)), line in zip(cases.items(), lines, strict=True):
        assert line.startswith(f"{paths[name]}: "), line
        for text in expected:
            assert text in line, f"{name}: {text!r} not in {line!r}"


def test_1_deeply_nested_json(tmp_path):
    """Nested 100000 deep: refused before decoding (json's C decoder would overflow the C
    stack, a segfault, wherever the recursion limit has been raised), in an instance and in a
    plan loaded by ``evaluate``."""
    check_validate(tmp_path, {
        "deep-list": ("[" * 100000 + "]" * 100000, ["invalid JSON: nested more than 100 levels deep", "100000"]),
        "deep-object": ('{"area": ' * 100000 + "1" + "}" * 100000, ["nested more than 100 levels deep"]),
    })
    plan = write(tmp_path, "deep-plan", '{"positions": ' + "[" * 100000 + "]" * 100000 + ', "schedule": []}')
    r = voiopt("evaluate", str(CASE_STUDY), str(plan), cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.splitlines() == [f"voiopt: error: {plan}: invalid JSON: nested more than 100 levels deep "
                                     "(a voiopt file nests at most 6), got 100001"]


def test_2_huge_numbers(tmp_path):
    """Huge values in every kind of field: a clear message, never an overflow or allocation."""
    huge_int = json.dumps(GOOD).replace('"horizon": 10', '"horizon": ' + "9" * 5000)  # over Python's 4300 digits
    check_validate(tmp_path, {
        "width": (changed(lambda d: d["area"].update(width=1e308)), ["area.width:", "at most 1000000 lattice points", "1e+308"]),
        "noise": (changed(lambda d: d["channel"].update(noise_dbm_per_hz=1e308)),
                  ["channel.noise_dbm_per_hz:", "[-3000, 3000]", "got 1e+308"]),
        "g0": (changed(lambda d: d["channel"].update(g0_db=1e308)), ["channel.g0_db:", "[-3000, 3000]", "got 1e+308"]),
        "power": (changed(lambda d: d["sensors"][0].update(power_w=1e308)),
                  ["sensors[0].power_w:", "power_w * g0 must be in [1e-300, 1e+300]", "got 1e+308"]),
        "aoi-1e30": (changed(lambda d: d["sensors"][1].update(initial_aoi=10**30)),
                     ["sensors[1].initial_aoi:", "initial_aoi + horizon <= 2000000", "got 1" + "0" * 30]),
        "aoi-2e70": (changed(lambda d: d["sensors"][2].update(initial_aoi=2**70)),
                     ["sensors[2].initial_aoi:", "<= 1999990", str(2**70)]),
        "int-beyond-float": (changed(lambda d: d["sensors"][0].update(rho=10**400)),
                             ["sensors[0].rho:", "must be finite", "an integer of 401 digits"]),
        "int-in-point": (changed(lambda d: d.update(start=[10**400, 0])), ["start[0]:", "an integer of 401 digits"]),
        "int-5000-digits": (huge_int, ["horizon:", "<= 1000000", "an integer of 5000 digits"]),
        "horizon": (changed(lambda d: d.update(horizon=10**30)), ["horizon:", "<= 1000000"]),
        "step": (changed(lambda d: d.update(step=1e-300)), ["step:", "at most 1000000 lattice points", "got 1e-300"]),
    })


def test_3_caps_and_derived_numbers(tmp_path):
    """What no method can hold, and numbers that only overflow once derived: each message
    says the limit."""
    check_validate(tmp_path, {
        "horizon": (changed(lambda d: d.update(horizon=10**6 + 1)), ["horizon:", "<= 1000000 (the cap on slots)", "1000001"]),
        "lattice-overflow": (changed(lambda d: d.update(area={"width": 1.7e308, "height": 5}, step=1e-10)),
                             ["step:", "at most 1000000 lattice points", "more than 1e+308"]),
        "lattice": (changed(lambda d: d.update(area={"width": 1000, "height": 1000})),
                    ["area.width:", "at most 1000000 lattice points", "1002001 (1001 x 1001)"]),
        "sensors": (changed(lambda d: d.update(sensors=d["sensors"] * 3334)), ["sensors:", "at most 10000 sensors", "10002"]),
        "pairs": (changed(lambda d: d.update(area={"width": 999, "height": 999})),
                  ["sensors:", "at most 2000000 sensor-lattice point pairs", "3 sensors on 1000000 lattice points"]),
        "bandwidth": (changed(lambda d: d["channel"].update(bandwidth_hz=1e301)), ["channel.bandwidth_hz:", "<= 1e+300"]),
        "b-n0": (changed(lambda d: d["channel"].update(bandwidth_hz=1e250, noise_dbm_per_hz=1000)),
                 ["channel.bandwidth_hz:", "bandwidth_hz * N0 must be in [1e-300, 1e+300]"]),
        "g0-underflow": (changed(lambda d: d["channel"].update(g0_db=-3500)), ["channel.g0_db:", "[-3000, 3000]", "-3500"]),
        "n0-underflow": (changed(lambda d: d["channel"].update(noise_dbm_per_hz=-3500)), ["channel.noise_dbm_per_hz:", "-3500"]),
        "inf-literal": (json.dumps(GOOD).replace('"rho": 0.7', '"rho": 1e400'), ["sensors[0].rho:", "must be finite"]),
        "nan-literal": (json.dumps(GOOD).replace('"rho": 0.7', '"rho": NaN'), ["invalid JSON: NaN is not allowed"]),
        "initial-distance": (changed(lambda d: d["sensors"][0].update(initial_distance=1e300)),
                             ["sensors[0].initial_distance:", "SNR", "1e-300", "got 1e+300"]),
        "name": (changed(lambda d: d.update(name="../../outside")), ['name:', 'without / or', '"../../outside"']),
        "key": (changed(lambda d: d["sensors"][0].update({"a\nb": 1})), ['sensors[0]."a\\nb": unknown field']),
    })


def test_4_positions_against_the_area(tmp_path):
    check_validate(tmp_path, {
        "sensor-outside": (changed(lambda d: d["sensors"][1].update(position=[5.5, 1])),
                           ["sensors[1].position:", "must lie in the area [0, 5] x [0, 5]", "[5.5, 1.0]"]),
        "start-off-lattice": (changed(lambda d: d.update(start=[0.5, 2])), ["start:", "must be a lattice point", "[0.5, 2.0]"]),
        "start-outside": (changed(lambda d: d.update(start=[1e300, 2])), ["start:", "must lie in the area", "1e+300"]),
        "tiny-step": (changed(lambda d: d.update(step=1e-5)),
                      ["step:", "at most 1000000 lattice points", "250001000001 (500001 x 500001)", "got 1e-05"]),
    })


def _plan(edit) -> dict:
    p = copy.deepcopy(GOOD_PLAN)
    edit(p)
    return p


@pytest.mark.parametrize("content,expected", [
    (_plan(lambda p: p.update(positions=[[0, 2]] * (10**6 + 1))),
     "positions: must have at most 1000000 entries (the cap on the horizon), got 1000001"),
    (_plan(lambda p: p["positions"].__setitem__(3, "x")), 'positions[3]: must be a pair [x, y] of finite numbers, got "x"'),
    (_plan(lambda p: p["positions"].__setitem__(3, [[[[1]]]] * 5000)),
     "positions[3]: must be a pair [x, y] of finite numbers, got [[[[1]]], [[[1]]], [[[1]]], [[[1]]], [[[1]]], [[[1]]], [[..."),
    (_plan(lambda p: p["schedule"].__setitem__(2, 10**400)),
     "schedule[2]: must be a sensor index or null, got an integer of 401 digits (an instance has at most 10000 sensors)"),
    (json.dumps(GOOD_PLAN).replace('"schedule": [', '"schedule": [' + "9" * 5000 + ", "),
     "schedule[0]: must be a sensor index or null, got an integer of 5000 digits (an instance has at most 10000 sensors)"),
    (_plan(lambda p: p["positions"].__setitem__(1, [10**400, 2])),
     "positions[1]: must be a pair [x, y] of finite numbers, got [an integer of 401 digits, 2]"),
], ids=["huge-list", "non-list-entry", "nested-entry", "huge-schedule-int", "5000-digit-schedule-int", "huge-position-int"])
def test_5_hostile_plans(tmp_path, content, expected):
    plan = write(tmp_path, "plan", content)
    r = voiopt("evaluate", str(CASE_STUDY), str(plan), cwd=tmp_path)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "Traceback" not in r.stderr and r.stdout == ""
    assert r.stderr.splitlines() == [f"voiopt: error: {plan}: {expected}"]


def test_6_a_key_given_twice(tmp_path):
    """A key given twice in one object is refused with its name, shortened (Python's decoder
    would keep the last one silently): in an instance, in a sensor of it, and in a plan (also
    when the decoder's slow path for long integers runs)."""
    text = json.dumps(GOOD)
    check_validate(tmp_path, {
        "top": (text.replace('"horizon": ', '"horizon": 7, "horizon": ', 1), ["invalid JSON", '"horizon" is given twice']),
        "sensor": (text.replace('"rho": ', '"rho": 0.5, "rho": ', 1), ["invalid JSON", '"rho" is given twice']),
        "long-int": (text.replace('"horizon": ', '"note": ' + "9" * 5000 + ', "horizon": 7, "horizon": ', 1),
                     ['"horizon" is given twice']),
        "long-key": ('{"' + "k" * 10**6 + '": 1, "' + "k" * 10**6 + '": 2}', ['"kkkk', 'kkk... is given twice']),
    })
    plan = write(tmp_path, "plan", json.dumps(GOOD_PLAN).replace('"schedule": ', '"schedule": [], "schedule": ', 1))
    r = voiopt("evaluate", str(CASE_STUDY), str(plan), cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.splitlines() == [f'voiopt: error: {plan}: invalid JSON: the key "schedule" is given twice in one object']
