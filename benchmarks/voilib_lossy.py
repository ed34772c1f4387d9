"""VoI-Lib's lossy set: the table of ``voiopt bench list --markdown`` (its lossy rows, as the tool
writes them) and each shipped lossy certificate in detail (what its value and bound are, the
plan's exact expected value, the value of adaptivity, the information-relaxation bound where
computed, policy-dp's states and seconds as certify recorded them, the stored policy's size). With ``--certify``, first
certifies the lossy set afresh into a temporary --work folder (``voiopt bench certify --only``
with the time limit given) and reports the wall time, and that its certificates agree with
the shipped ones (``voiopt bench merge-certificates`` into a copy: nothing to change).
Writes docs/results/voilib_lossy.md.

    python benchmarks/voilib_lossy.py [--certify] [--time-limit 60]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from voiopt.core.links import is_lossy
from voiopt.objectives import gap
from voiopt.voilib import library as voilib

VOIOPT = [sys.executable, "-m", "voiopt"]


def certify(names: list[str], time_limit: float) -> None:
    work = Path(tempfile.mkdtemp(prefix="voilib-lossy-"))
    try:
        t0 = time.perf_counter()
        subprocess.run([*VOIOPT, "bench", "certify", "--work", str(work / "work"), "--only", ",".join(names),
                        "--time-limit", str(time_limit), "--quiet"], check=True, stdout=subprocess.DEVNULL)
        seconds = time.perf_counter() - t0
        copy = work / "shipped.json"
        shutil.copyfile(str(voilib.DATA / "certificates.json"), copy)
        merged = subprocess.run([*VOIOPT, "bench", "merge-certificates", str(work / "work"), "--into", str(copy)],
                                capture_output=True, text=True)
        print(f"certified {len(names)} lossy instances x 4 objectives in {seconds:.0f} s (--time-limit {time_limit:g}, "
              f"one process); merged into a copy of the shipped file: {merged.stdout.strip() or merged.stderr.strip()}")
        print()
    finally:
        shutil.rmtree(work, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--certify", action="store_true", help="certify the lossy set afresh first, timed")
    ap.add_argument("--time-limit", type=float, default=60.0)
    args = ap.parse_args()
    names = [n for n, inst in voilib.instances().items() if is_lossy(inst)]
    if args.certify:
        certify(names, args.time_limit)
    listed = subprocess.run([*VOIOPT, "bench", "list", "--markdown"], check=True, capture_output=True,
                            text=True).stdout.splitlines()
    print("\n".join(listed[:2] + [line for line in listed[2:] if line.split(" | ")[0].strip("| ") in names]))
    print()
    print("| instance | objective | status | value (exact) of | bound kind | plan's exact value | "
          "adaptivity | lossless bound | information relaxation | policy-dp |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    certs = voilib.certificates()["instances"]
    for name in names:
        for objective, c in certs[name]["certificates"].items():
            pdp = c["checks"].get("policy-dp")
            ran = "-" if pdp is None else (f"{pdp['states']:,} policy states, {pdp['runtime_s']:.1f} s" if pdp["value"] is not None
                                           else f"{pdp['status']} ({pdp['runtime_s']:.0f} s)")
            if c.get("policy_file"):
                ran += f", stored ({(voilib.DATA / c['policy_file']).stat().st_size / 1000:.0f} kB)"
            ir = c["information_relaxation"]
            ir = "-" if ir is None else f"{ir['bound']:.6g} ({ir['samples']} scenarios, {ir['confidence']:.0%})"
            adaptivity = f"{100 * gap(c['plan_value'], c['value']):.2f} %" if c["value_of"] == "policy" else "-"
            print(f"| {name} | {objective} | {c['status']} | {c['value']:.6g} ({c['value_of']}) | {c['bound_kind']} | "
                  f"{c['plan_value']:.6g} | {adaptivity} | {c['lossless_bound']:.6g} | {ir} | {ran} |")
    print()
    print(json.dumps({"policy-dp not finished": [f"{n} {o}" for n in names for o, c in certs[n]["certificates"].items()
                                                 if "policy-dp" in c["checks"] and c["status"] != "optimal"]}))


if __name__ == "__main__":
    import report

    sys.exit(report.run("voilib_lossy", main))
