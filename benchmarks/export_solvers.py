"""Other solvers on voiopt's exported MILP: every VoI-Lib min-voi and mean-min-voi export,
solved by HiGHS and by SCIP at their default settings with a relative gap of 0, each solution
read back by ``import-solution`` and its simulated value compared with the certificate.

    .venv/bin/python benchmarks/export_solvers.py [--time-limit 4] [--solvers highs scip]
        [--only NAME ...] [--objectives min-voi mean-min-voi] [--name export_solvers]

Requirements: highspy (a voiopt dependency) and pyscipopt (``pip install 'voiopt[scip]'``).
Each solve gets ``--time-limit`` seconds; a solve stopped by it is reported as ``time limit``
with the value of the plan it had. An "optimal" solve must match the certificate to 1e-6
relative (the tolerance of an ``optimal`` claim, MODEL.md section 6); one that does not is a
misread (exit status 1). The table is printed and written to docs/results/NAME.md by
benchmarks/report.py, with the command, commit, date and machine in its header.
"""

from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
import tempfile
import time
from pathlib import Path

from voiopt.solvers.milp.export import export
from voiopt.solvers.milp.solution_file import import_solution
from voiopt.voilib import library as voilib

MATCH_RTOL = 1e-6  # an optimal claim's tolerance (MODEL.md section 6)


def solve_highs(mps: Path, sol: Path, time_limit: float) -> tuple[str, float | None]:
    """HiGHS on the file at its defaults, mip_rel_gap 0: (status, objective), the solution
    written in the raw style that import-solution reads (if HiGHS has one)."""
    import highspy

    h = highspy.Highs()
    h.silent()
    h.readModel(str(mps))
    h.setOptionValue("mip_rel_gap", 0.0)
    h.setOptionValue("time_limit", float(time_limit))
    h.setOptionValue("threads", 1)
    h.run()
    status = h.modelStatusToString(h.getModelStatus())
    info = h.getInfo()
    if info.primal_solution_status != 2:
        return status, None
    h.writeSolution(str(sol), 0)
    return status, float(info.objective_function_value)


def solve_scip(mps: Path, sol: Path, time_limit: float) -> tuple[str, float | None]:
    """SCIP (pyscipopt) on the file at its defaults, limits/gap 0."""
    import pyscipopt

    m = pyscipopt.Model()
    m.hideOutput()
    m.readProblem(str(mps))
    m.setParam("limits/gap", 0.0)
    m.setParam("limits/time", float(time_limit))
    m.setParam("parallel/maxnthreads", 1)
    m.optimize()
    status = m.getStatus()
    if m.getNSols() == 0:
        return status, None
    m.writeBestSol(str(sol))
    return status, float(m.getObjVal())


SOLVERS = {"highs": solve_highs, "scip": solve_scip}
OPTIMAL = {"Optimal", "optimal"}
STOPPED = {"Time limit reached", "timelimit"}


def model_worth(objective: str, value: float | None) -> float | None:
    """The solver's objective value as a worth in bit/s: min-voi files state ln(V)."""
    if value is None:
        return None
    return math.exp(value) if objective == "min-voi" else value


def run_one(name: str, inst, objective: str, solver: str, time_limit: float, folder: Path) -> dict:
    cert = voilib.certified(inst, objective)
    mps = folder / f"{name}-{objective}.mps"
    if not mps.exists():
        export(inst, objective, mps)
    sol = folder / f"{name}-{objective}-{solver}.sol"
    t = time.perf_counter()
    status, claimed = SOLVERS[solver](mps, sol, time_limit)
    seconds = time.perf_counter() - t
    value = None
    if claimed is not None:
        value = import_solution(inst, objective, mps, sol).value
    match = value is not None and cert is not None and abs(value - cert) <= MATCH_RTOL * abs(cert)
    if status in OPTIMAL:
        outcome = "equal" if match else "MISREAD"
    elif status in STOPPED:
        outcome = "time limit" + (" (equal)" if match else "")
    else:
        outcome = status
    return {"instance": name, "objective": objective, "solver": solver, "status": status, "seconds": seconds,
            "claimed": model_worth(objective, claimed), "value": value, "certified": cert, "outcome": outcome}


def fmt(v: float | None) -> str:
    return "-" if v is None else f"{v:.10g}"


def settings() -> str:
    """What the results table's reader needs beside report.py's header: the load, the solvers'
    versions and what the outcomes mean."""
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    import highspy
    try:
        import pyscipopt
        scip = f"pyscipopt {pyscipopt.__version__}"
    except ImportError:
        scip = "pyscipopt not installed"
    return (f"load {load:.1f} at the start; highspy {highspy.Highs().version()}, {scip}; each solver's defaults, "
            f"relative gap 0, one thread. equal: the plan read back by import-solution is worth the certified "
            f"optimum to {MATCH_RTOL:g} relative; MISREAD: the solver said optimal and it is not; claimed: the "
            "solver's own objective in bit/s (exp of a min-voi file's ln V)")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--time-limit", type=float, default=4.0, help="seconds per solve (default 4)")
    ap.add_argument("--solvers", nargs="+", default=list(SOLVERS), choices=list(SOLVERS))
    ap.add_argument("--objectives", nargs="+", default=["min-voi", "mean-min-voi"],
                    choices=["min-voi", "mean-min-voi"])
    ap.add_argument("--only", nargs="+", default=None, help="VoI-Lib instance names")
    ap.add_argument("--name", default="export_solvers", help="the results table, docs/results/NAME.md")
    args = ap.parse_args(argv)
    insts = voilib.instances()
    names = args.only or [n for n, inst in insts.items() if inst.links is None]  # the lossy set has no MILP optimum
    head = settings()
    rows = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            for objective in args.objectives:
                for solver in args.solvers:
                    r = run_one(name, insts[name], objective, solver, args.time_limit, Path(tmp))
                    rows.append(r)
                    print(f"{name:24} {objective:13} {solver:6} {r['outcome']:18} {r['seconds']:6.2f} s  "
                          f"value {fmt(r['value'])}  certified {fmt(r['certified'])}", flush=True)
    lines = ["| instance | objective | solver | outcome | status | s | claimed | value (simulated) | certified |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['instance']} | {r['objective']} | {r['solver']} | {r['outcome']} | {r['status']} | "
                     f"{r['seconds']:.2f} | {fmt(r['claimed'])} | {fmt(r['value'])} | {fmt(r['certified'])} |")
    summary = []
    for solver in args.solvers:
        for objective in args.objectives:
            mine = [r for r in rows if r["solver"] == solver and r["objective"] == objective]
            count = {k: sum(r["outcome"].split(" (")[0] == k for r in mine) for k in ("equal", "MISREAD", "time limit")}
            summary.append(f"| {solver} | {objective} | {len(mine)} | {count['equal']} | {count['time limit']} | "
                           f"{count['MISREAD']} | {len(mine) - sum(count.values())} |")
    text = "\n".join([head, "", "| solver | objective | solves | equal | time limit | MISREAD | other |",
                      "|---|---|---|---|---|---|---|", *summary, "",
                      f"Total wall time {time.perf_counter() - t0:.0f} s.", "", *lines, ""])
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import report

    path = report.write(args.name, "python " + shlex.join(["benchmarks/export_solvers.py", *argv]), text)
    print("\n".join(summary))
    print(f"written to {path}" if path else "not written (VOIOPT_RESULTS_DIR=-)")
    return 1 if any(r["outcome"] == "MISREAD" for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
