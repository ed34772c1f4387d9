"""The docs state the method and current results: no dated narrative, and every results table
says how it was made (command, commit, date, machine). Fast: reads files only."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
RESULTS = DOCS / "results"
#: docs/*.md that the rules cover: MODEL.md is a copy of the model contract, results/ is generated
PAGES = sorted(p for p in DOCS.glob("*.md") if p.name != "MODEL.md")
MONTHS = "Jan|Feb|Mar|Apr|May|Jun|Jul|Aug|Sep|Sept|Oct|Nov|Dec"
DATE = re.compile(rf"\b\d{{4}}-\d{{2}}-\d{{2}}\b|\b(?:{MONTHS})[a-z]*\.? \d{{1,2}}\b|\b\d{{1,2}} (?:{MONTHS})[a-z]*\b")
#: a commit hash: 7 to 12 hex digits with at least one letter and one digit
COMMIT = re.compile(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,12}\b")
DIARY = ("this session", "earlier sessions", "earlier session", "later hour", "a review found",
         "fuzz campaign", "measured again", "this morning", "the same day", "the day before",
         "a fresh-eyes probe", "a probe found", "an outside probe", "until 20", "since 20")
SESSION = re.compile(r"\b(?:first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|"
                     r"twelfth|thirteenth|fourteenth|\d+(?:st|nd|rd|th)) session\b", re.IGNORECASE)
MAX_DATES = 3
MAX_CELL = 320


def _load_report():
    spec = importlib.util.spec_from_file_location("report", ROOT / "benchmarks" / "report.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_rules_see_every_method_page():
    names = {p.name for p in PAGES}
    assert {"dp.md", "qlearning.md", "milp.md", "voilib.md", "model.md", "reproduce.md", "reliability.md"} <= names


def test_the_date_pattern_finds_the_forms_it_must():
    for text in ("on 2026-12-04 we", "on Dec 4 we", "December 14, a", "on 4 Dec"):
        assert DATE.search(text), text
    for text in ("N = 4, T = 30", "seed2026-002", "`max-aoi` 101", "1e-6 to 1000 W"):
        assert not DATE.search(text), text


def test_at_most_three_date_stamps_across_the_pages():
    found = [(p.name, m.group()) for p in PAGES for m in DATE.finditer(p.read_text(encoding="utf-8"))]
    assert len(found) <= MAX_DATES, found


def test_no_commit_hashes_in_the_pages():
    found = [(p.name, m.group()) for p in PAGES for m in COMMIT.finditer(p.read_text(encoding="utf-8"))]
    assert not found, found


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_no_diary_phrases(page):
    text = page.read_text(encoding="utf-8")
    lower = " ".join(text.lower().split())
    assert [w for w in DIARY if w in lower] == []
    assert SESSION.findall(text) == []


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_link_to_a_results_table_resolves(page):
    for target in re.findall(r"\]\((results/[^)#]+)", page.read_text(encoding="utf-8")):
        assert (DOCS / target).is_file(), f"{page.name} links to missing {target}"


def test_the_method_pages_link_to_their_results():
    for name in ("dp.md", "qlearning.md", "milp.md"):
        assert "](results/" in (DOCS / name).read_text(encoding="utf-8"), name


def test_every_results_table_has_the_header_fields():
    report = _load_report()
    tables = sorted(RESULTS.glob("*.md"))
    assert tables
    for table in tables:
        head = table.read_text(encoding="utf-8").split("\n\n")[:3]
        fields = dict(re.findall(r"^- (\w+): (.+)$", "\n".join(head), re.MULTILINE))
        assert set(report.FIELDS) <= set(fields), (table.name, sorted(fields))
        assert all(fields[f].strip() for f in report.FIELDS), table.name
        assert fields["Source"] in (report.MEASURED, report.CARRIED), table.name
        assert "rev-parse" not in fields["Commit"]


def test_reliability_is_a_table_of_guarantees_each_with_an_existing_test():
    text = (DOCS / "reliability.md").read_text(encoding="utf-8")
    rows = [line for line in text.splitlines() if line.startswith("| ") and not line.startswith("| guarantee")]
    assert len(rows) >= 30
    for row in rows:
        cells = [c.strip() for c in row.strip().strip("|").split(" | ")]
        assert len(cells) == 2, row[:80]
        assert all(len(c) <= MAX_CELL for c in cells), row[:80]
        refs = re.findall(r"`(tests/[\w/]+\.py)::(test_\w+)`", cells[1])
        assert refs or cells[1].startswith("not tested"), row[:80]
        for path, name in refs:
            source = (ROOT / path).read_text(encoding="utf-8")
            assert re.search(rf"^def {name}\(", source, re.MULTILINE), f"{path}::{name} does not exist"


def test_a_results_table_is_written_atomically_with_its_header_and_body(tmp_path, monkeypatch):
    report = _load_report()
    monkeypatch.setenv("VOIOPT_RESULTS_DIR", str(tmp_path))
    printed = "# a note\n| a | b |\n|---|---|\n| 1 | 2 |\nload average 1.0\n"
    path = report.write("demo", "python benchmarks/demo.py --quick", printed)
    text = path.read_text(encoding="utf-8")
    assert path == tmp_path / "demo.md" and [p.name for p in tmp_path.iterdir()] == ["demo.md"]
    assert "- Command: `python benchmarks/demo.py --quick`" in text
    commit = re.search(r"^- Commit: (\S+)", text, re.MULTILINE).group(1)
    assert re.fullmatch(r"[0-9a-f]{7,12}(\+dirty)?|unknown", commit)
    assert re.search(r"^- Date: \d{4}-\d{2}-\d{2} \d{2}:\d{2} UTC$", text, re.MULTILINE)
    assert re.search(r"^- Machine: .+, \d+ cores, ", text, re.MULTILINE)
    assert re.search(r"^- Software: Python \d+\.\d+\.\d+, numpy ", text, re.MULTILINE)
    assert "```text\n# a note\n```" in text and "| a | b |\n|---|---|\n| 1 | 2 |" in text
    assert "```text\nload average 1.0\n```" in text


def test_a_quick_look_can_leave_the_tables_alone(monkeypatch):
    report = _load_report()
    monkeypatch.setenv("VOIOPT_RESULTS_DIR", "-")
    assert report.write("demo", "python benchmarks/demo.py", "| a |\n") is None


def test_run_keeps_what_main_prints_and_names_the_table(tmp_path, monkeypatch, capsys):
    report = _load_report()
    monkeypatch.setenv("VOIOPT_RESULTS_DIR", str(tmp_path))
    monkeypatch.setenv("VOIOPT_RESULTS_NAME", "renamed")
    monkeypatch.setattr("sys.argv", ["benchmarks/demo.py", "--settings", "a b"])
    assert report.run("demo", lambda: print("| x |\n|---|\n| 3 |") or 1) == 1
    assert "| 3 |" in capsys.readouterr().out
    text = (tmp_path / "renamed.md").read_text(encoding="utf-8")
    assert "`python benchmarks/demo.py --settings 'a b'`" in text and "| 3 |" in text


def test_several_runs_combine_into_one_table_naming_every_command(tmp_path, monkeypatch):
    report = _load_report()
    monkeypatch.setenv("VOIOPT_RESULTS_DIR", str(tmp_path / "parts"))
    parts = [report.write(f"t.{i}", f"python benchmarks/x.py --flag {i}", f"| run |\n|---|\n| {i} |\n") for i in (0, 1)]
    monkeypatch.setenv("VOIOPT_RESULTS_DIR", str(tmp_path))
    text = report.combine("t", parts).read_text(encoding="utf-8")
    assert "- Command: `python benchmarks/x.py --flag 0; python benchmarks/x.py --flag 1`" in text
    assert text.index("Run: `python benchmarks/x.py --flag 0`") < text.index("| 0 |")
    assert text.index("| 0 |") < text.index("Run: `python benchmarks/x.py --flag 1`") < text.index("| 1 |")
    assert f"- Source: {report.MEASURED}" in text
