"""``make demo``: the main job on the shipped case study, with a short summary."""

from __future__ import annotations

from rich.console import Console
from rich.table import Table

from voiopt import instance
from voiopt.generate import CASE_STUDY_PLAN, case_study
from voiopt.result import Plan
from voiopt.simulate import OBJECTIVES, simulate


def run_demo(path: str | None, console: Console) -> int:
    inst = instance.load(path) if path else case_study()
    console.print(
        f"[bold]{inst.name}[/]: N = {inst.n_sensors} sensors, T = {inst.horizon} slots, "
        f"{inst.width:g} x {inst.height:g} m area, start {list(inst.start)}"
    )
    table = Table(title="plans on the case study (every value simulated)")
    table.add_column("plan")
    for m in OBJECTIVES:
        table.add_column(m, justify="right")
    rows = {"example plan (hand-made)": Plan.from_dict(CASE_STUDY_PLAN)} if not path else {}
    for name, plan in rows.items():
        metrics = simulate(inst, plan).metrics
        table.add_row(name, *(f"{metrics[m]:.6g}" for m in OBJECTIVES))
    console.print(table)
    return 0
