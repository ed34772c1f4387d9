"""``voiopt bench score``'s columns: a lossy row (MODEL.md section 11) says how its value was
computed (exact, or Monte Carlo with its CI and scenario count) and its bound's kind, in the
table, --json and --csv; where no row is lossy the output is as it always was."""

from __future__ import annotations

import csv
import io
import json

import pytest
from conftest import run_cli

from voiopt.cli.bench import LOSSY_CSV, LOSSY_KEYS, SCORE_COLUMNS
from voiopt.core.result import BoundKind, Evaluation
from voiopt.voilib import library as voilib


@pytest.fixture(scope="module")
def solutions(tmp_path_factory):
    folder = tmp_path_factory.mktemp("lib")
    voilib.export(folder)
    return [str(p) for p in sorted((folder / "solutions").glob("case-study__*"))[:3]]


@pytest.fixture
def lossy_rows(solutions, monkeypatch):
    """The rows of three shipped solutions, the first two labelled as a lossy scorer would
    label them: a Monte Carlo value with its CI, an exact one; the third lossless."""
    rows, errors = voilib.score_files(solutions)
    assert not errors
    v = rows[0]["value"]
    rows[0] |= {"evaluation": Evaluation.MONTE_CARLO, "samples": 500, "value_ci": [v - 0.25, v + 0.75],
                "bound_kind": BoundKind.LOSSLESS}
    rows[1] |= {"evaluation": Evaluation.EXACT, "samples": None, "value_ci": None, "bound_kind": BoundKind.EXACT}
    monkeypatch.setattr(voilib, "score_files", lambda paths, instance=None, objective=None: (rows, []))
    return rows


def test_lossless_rows_have_no_lossy_columns(capsys, solutions):
    code, out, _ = run_cli(capsys, "bench", "score", "--json", *solutions)
    assert code == 0 and all(list(r) == list(SCORE_COLUMNS) for r in json.loads(out))
    code, out, _ = run_cli(capsys, "bench", "score", "--csv", *solutions)
    assert code == 0 and next(csv.reader(io.StringIO(out))) == list(SCORE_COLUMNS)
    code, out, _ = run_cli(capsys, "bench", "score", *solutions)
    assert code == 0 and "evaluation" not in out and "bound kind" not in out


def test_lossy_rows_carry_evaluation_ci_and_bound_kind_in_json(capsys, lossy_rows, solutions):
    code, out, _ = run_cli(capsys, "bench", "score", "--json", *solutions)
    got = json.loads(out)
    assert code == 0 and all(list(r) == [*SCORE_COLUMNS, *LOSSY_KEYS] for r in got)
    v = lossy_rows[0]["value"]
    assert {k: got[0][k] for k in LOSSY_KEYS} == {"evaluation": "monte-carlo", "samples": 500,
                                                  "value_ci": [v - 0.25, v + 0.75], "bound_kind": "lossless"}
    assert (got[1]["evaluation"], got[1]["value_ci"], got[1]["bound_kind"]) == ("exact", None, "exact")
    assert all(got[2][k] is None for k in LOSSY_KEYS)  # the lossless row: empty


def test_lossy_rows_carry_evaluation_ci_and_bound_kind_in_csv_and_the_table(capsys, lossy_rows, solutions):
    code, out, _ = run_cli(capsys, "bench", "score", "--csv", *solutions)
    got = list(csv.DictReader(io.StringIO(out)))
    assert code == 0 and list(got[0]) == [*SCORE_COLUMNS, *LOSSY_CSV]
    v = lossy_rows[0]["value"]
    assert (got[0]["evaluation"], got[0]["samples"], float(got[0]["value_ci_low"]), float(got[0]["value_ci_high"]),
            got[0]["bound_kind"]) == ("monte-carlo", "500", v - 0.25, v + 0.75, "lossless")
    assert (got[1]["evaluation"], got[1]["value_ci_low"], got[1]["bound_kind"]) == ("exact", "", "exact")
    assert all(got[2][k] == "" for k in LOSSY_CSV)
    code, out, _ = run_cli(capsys, "bench", "score", *solutions)
    assert code == 0 and "± 0.5" in out and "monte-carlo, 500 scenarios" in out and "bound kind" in out
