"""``voiopt bench`` (VoI-Lib: list, export, score, certify) and ``voiopt import-solution``: the
commands for people scoring their own methods. Thin, like cli.py: parse, call, print."""

from __future__ import annotations

import csv
import sys

from rich.console import Console
from rich.table import Table

from voiopt.core import instance as instance_mod
from voiopt.errors import OptionError, PlanError, VoioptError
from voiopt.objectives import DEFAULT, OBJECTIVES
from voiopt.runtime.files import check_output_dir, check_output_file, dumps_json

out = Console(highlight=False, soft_wrap=True)
err = Console(stderr=True, highlight=False, soft_wrap=True)
wide = Console(highlight=False, width=None if out.is_terminal else 200)  # tables are not cut to 80 columns in a pipe


def cmd_bench_list(args) -> int:
    from voiopt.voilib import library as voilib

    rows = voilib.table_rows()
    cols = voilib.LIST_COLUMNS  # with links; a lossy certificate names its bound's kind
    if args.markdown:
        print("\n".join(voilib.voilib_export.markdown(rows)))
        return 0
    t = Table(title=f"VoI-Lib {voilib.VERSION}: the optimum, or \\[lower, upper] where still open")
    for col in cols:
        t.add_column(col, justify="right" if col in ("N", "T") or col in OBJECTIVES else "left")
    for r in rows:
        t.add_row(*(str(r[c]) for c in cols))
    wide.print(t)
    return 0


def cmd_bench_export(args) -> int:
    from voiopt.voilib import library as voilib

    check_output_dir(args.out, "--out")
    folder = voilib.export(args.out, overwrite=args.overwrite)
    out.print(f"wrote {len(voilib.instances())} instances, certificates.json, README.md and solutions/ to {folder}",
              markup=False)
    return 0


SCORE_COLUMNS = ("result", "instance", "objective", "status", "value", "certified_status", "certified_value",
                 "certified_bound", "gap_to_bound", "gap_to_best")
# a lossy row's labels (MODEL.md section 11; a row without them is lossless): the keys a row carries,
# and the columns --csv and the table give them (value_ci as its two ends)
LOSSY_KEYS = ("evaluation", "samples", "value_ci", "bound_kind")
LOSSY_CSV = ("evaluation", "samples", "value_ci_low", "value_ci_high", "bound_kind")


def score_columns(rows) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The JSON keys and CSV columns of ``bench score``: SCORE_COLUMNS, and where some row is
    lossy (has an ``evaluation``) the lossy labels too; every lossless row leaves them empty,
    and a report with no lossy row is as it always was."""
    if not any(r.get("evaluation") is not None for r in rows):
        return SCORE_COLUMNS, SCORE_COLUMNS
    return SCORE_COLUMNS + LOSSY_KEYS, SCORE_COLUMNS + LOSSY_CSV


def _csv_cells(r) -> dict:
    ci = r.get("value_ci")
    return {**r, "value_ci_low": None if ci is None else ci[0], "value_ci_high": None if ci is None else ci[1]}


def _value_cell(r) -> str:
    ci = r.get("value_ci")
    return f"{r['value']:.6g}" + ("" if ci is None else f" ± {(ci[1] - ci[0]) / 2:.3g}")


def _how_cell(r) -> str:
    """A lossy row's evaluation, as the table says it; "-" for a lossless one."""
    if r.get("evaluation") is None:
        return "-"
    return str(r["evaluation"]) + ("" if r.get("samples") is None else f", {r['samples']} scenarios")


def cmd_bench_score(args) -> int:
    from voiopt.voilib import library as voilib

    if args.json and args.csv:
        raise OptionError("--json and --csv: give one")
    rows, errors = voilib.score_files(args.results, args.instance, args.objective)  # a forged value, an illegal plan: 2
    keys, columns = score_columns(rows)
    if args.json:
        print(dumps_json([{c: r.get(c) for c in keys} for r in rows]))
    elif args.csv:
        w = csv.writer(sys.stdout, lineterminator="\n")
        w.writerow(columns)
        w.writerows([["" if r.get(c) is None else repr(r[c]) if isinstance(r[c], float) else r[c] for c in columns]
                     for r in map(_csv_cells, rows)])
    elif rows:
        lossy = keys != SCORE_COLUMNS
        t = Table(title="gap to the VoI-Lib certificate (re-simulated)" + (
            "; a lossy value is exact or Monte Carlo ± its 95 % CI's half-width" if lossy else ""))
        heads = ("result", "instance", "objective", "status", "value", *(("evaluation",) if lossy else ()),
                 "certified", *(("bound kind",) if lossy else ()), "gap to bound", "gap to best")
        for col in heads:
            t.add_column(col)
        pct = lambda g: "-" if g is None else f"{100 * g:.4g} %"  # noqa: E731
        for r in rows:
            how = (_how_cell(r),) if lossy else ()
            kind = (str(r.get("bound_kind") or "-"),) if lossy else ()
            t.add_row(r["result"], r["instance"], r["objective"], r["status"] or "-", _value_cell(r), *how,
                      r["certified"], *kind, pct(r["gap_to_bound"]), pct(r["gap_to_best"]))
        wide.print(t)
    for e in errors[:-1]:  # one line each; the last is main's, with exit status 2
        err.print(f"voiopt: error: {e}", markup=False)
    if errors:
        raise errors[-1]
    return 0


CHECK_HELP = "the checker: exit 0 valid, 3 illegal plan, 4 wrong claimed value, 5 unreadable file, 2 other bad input"


def cmd_bench_check(args) -> int:
    """The checker: exit 0 valid, 3 an illegal plan, 4 a wrong claimed value, 5 an unreadable
    file, 2 other bad input (voiopt.voilib.export.CHECK_CODES, docs/voilib.md)."""
    from voiopt.voilib import library as voilib

    try:
        rows, errors = voilib.score_files([args.result], args.instance, args.objective)
        if errors:
            raise errors[0]
    except VoioptError as e:
        code = (3 if isinstance(e, PlanError) else 4 if isinstance(e, voilib.ClaimError)
                else 5 if isinstance(e, voilib.UnreadableError) else 2)
        err.print(f"voiopt: error: {e}", markup=False)
        return code
    r = rows[0]
    gap = "-" if r["gap_to_bound"] is None else f"{100 * r['gap_to_bound']:.4g} %"
    out.print(f"valid: {r['instance']} {r['objective']} {r['value']!r} (gap to bound {gap})", markup=False)
    return 0


def cmd_bench_certify(args) -> int:
    from voiopt.voilib import library as voilib

    path = voilib.certify(args.work, time_limit=args.time_limit, memory_limit=args.memory_limit,
                          workers=args.workers, dask_scheduler=args.dask_scheduler, progress=not args.quiet,
                          into=args.into, only=None if args.only is None else args.only.split(","),
                          threads=args.threads)
    out.print(f"wrote {path}", markup=False)
    return 0


def cmd_bench_merge(args) -> int:
    from voiopt.voilib import merge as voilib_merge

    path, changed = voilib_merge.merge(args.source, args.into)
    if changed:
        out.print(f"merged {len(changed)} certificates into {path}", markup=False)
    else:
        out.print(f"{path}: already holds these certificates; nothing written", markup=False)
    return 0


def cmd_import_solution(args) -> int:
    from voiopt.solvers.milp.solution_file import import_solution

    check_output_file(args.output, inputs=[("INSTANCE", args.instance), ("MODEL", args.model),
                                           ("SOLUTION", args.solution)])
    inst = instance_mod.load(args.instance)
    result = import_solution(inst, args.objective, args.model, args.solution)
    result.save(args.output)
    out.print(result.summary(), markup=False)
    out.print(f"result written to {args.output}", markup=False)
    return 0


def _add_bare(s) -> None:
    s.add_argument("--instance", default=None, metavar="NAME", help="a VoI-Lib instance: the files are bare plans "
                   "(positions and schedule) of it")
    s.add_argument("--objective", default=None, choices=list(OBJECTIVES), help="with --instance: the objective")


def add_commands(sub, command, add_executor_options, count) -> None:
    """The parsers of ``bench`` and ``import-solution``."""
    b = command(sub, "bench", "VoI-Lib: certified instances to score any method against", None)
    bench = b.add_subparsers(dest="bench_command", metavar="ACTION", required=True)
    s = command(bench, "list", "the instances, their sizes and certified values", cmd_bench_list)
    s.add_argument("--markdown", action="store_true", help="print a Markdown table")
    s = command(bench, "export", "write the instances, certificates.json, a README and the solutions to a folder", cmd_bench_export)
    s.add_argument("--out", required=True, metavar="DIR", help="the instances' JSON files and certificates.json go here")
    s.add_argument("--overwrite", action="store_true",
                   help="replace files in --out that hold other instances under the library's names (default: refuse, "
                        "write nothing)")
    s = command(bench, "score", "re-simulate results and print their gaps to the certificates", cmd_bench_score)
    s.add_argument("results", nargs="+", metavar="RESULT",
                   help="result JSON files with instance (or instance_sha256), objective and plan; a value, if given, "
                        "must be what the plan gives; with --instance, bare plans")
    _add_bare(s)
    s.add_argument("--json", action="store_true", help="print the rows as a JSON list (errors still on stderr)")
    s.add_argument("--csv", action="store_true", help="print the rows as CSV")
    s = command(bench, "check", CHECK_HELP, cmd_bench_check)
    s.add_argument("result", metavar="RESULT", help="a result JSON, or a bare plan with --instance")
    _add_bare(s)
    s = command(bench, "certify", "rebuild certificates.json with dp and the MILP (resumable)", cmd_bench_certify)
    s.add_argument("--work", required=True, metavar="DIR", help="where each run's result is kept, for resuming")
    s.add_argument("--time-limit", type=float, default=60.0, metavar="S", help="per run (default 60)")
    s.add_argument("--into", default=None, metavar="DIR",
                   help="where certificates.json goes (default: the --work folder; never the package's own: "
                        "bench merge-certificates updates those)")
    s.add_argument("--only", default=None, metavar="NAME,...", help="certify these instances alone")
    s.add_argument("--threads", type=count, default=1, metavar="K",
                   help="per run: dp's chunks expanded at once and the MILP's HiGHS threads (default 1)")
    add_executor_options(s)
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s = command(bench, "merge-certificates", "a maintainer's step: merge certificates that certify wrote into the "
                "shipped ones, refusing any weaker or disagreeing one", cmd_bench_merge)
    s.add_argument("source", metavar="SOURCE", help="a certificates.json, or the folder bench certify --into wrote it to")
    s.add_argument("--into", default=None, metavar="FILE",
                   help="the certificates.json to update (default: the package's shipped one)")

    s = command(sub, "import-solution", "read a MILP solver's solution back into a plan and a result",
                cmd_import_solution)
    s.add_argument("instance", metavar="INSTANCE", help="the instance JSON the model was exported from")
    s.add_argument("model", metavar="MODEL", help="the .mps or .lp that voiopt export wrote")
    s.add_argument("solution", metavar="SOLUTION",
                   help="HiGHS's solution file, or a 'name value' .sol file (SCIP, Gurobi, CPLEX)")
    s.add_argument("--objective", default=DEFAULT, choices=list(OBJECTIVES),
                   help="the objective the model was exported for (default mean-min-voi)")
    s.add_argument("-o", "--output", required=True, metavar="RESULT", help="the result JSON to write")
