"""``voiopt validate``: ok, or every error of each file; for a fleet whose joint plan validation
could not decide (too many joint points for the exact table), a short search, then ok, an
error, or a ``skipped:`` line and exit status 3 (docs/model.md, "Validating a fleet")."""

from __future__ import annotations

from rich.console import Console

from voiopt.core import instance as instance_mod
from voiopt.core.instance import Instance
from voiopt.errors import VoioptError
from voiopt.grid import lattice, places

out = Console(highlight=False, soft_wrap=True)
err = Console(stderr=True, highlight=False, soft_wrap=True)

JOINT_SEARCH_S = 2.0  # the conflict-free walker's time for a fleet the exact table cannot decide
UNDECIDED = 3  # exit status: every file legal, but some fleet's joint plan undecided


def joint_search(inst: Instance) -> tuple[bool | None, str]:
    """A fleet's joint plan, looked for by the conflict-free walker (greedy) for JOINT_SEARCH_S:
    (True, how) when it returns a legal plan (the simulator checked it), (False, why) when its
    search proved there is none, else (None, why it stayed undecided)."""
    import voiopt

    r = voiopt.solve(inst, method="greedy", time_limit=JOINT_SEARCH_S)  # any objective: only the plan counts
    if r.plan is not None:
        return True, f"greedy found a legal joint plan in {r.runtime_s:.2g} s"
    note = r.solver.get("note", r.status)
    if r.status == "infeasible":
        return False, note
    return None, note


def cmd_validate(args) -> int:
    bad = undecided = 0
    for path in args.instances:
        try:
            inst = instance_mod.load(path)
        except VoioptError as e:
            lines = [f"{path}: {line}" for line in getattr(e, "all_errors", [])] or [str(e)]
            for line in lines:
                err.print(line, markup=False)
            bad += 1
            continue
        never = lattice.unservable_sensors(inst)
        note = f" ({inst.n_robots} robots)" if inst.fleet else ""
        where = f"{path}: " if len(args.instances) > 1 else ""
        if inst.fleet and not places.joint_decided(inst.width, inst.height, inst.step, inst.horizon, inst.blocked,
                                                    inst.robots):
            found, why = joint_search(inst)
            if found is False:
                err.print(f"{path}: robots: no legal joint plan ({why}; MODEL.md section 10)", markup=False)
                bad += 1
                continue
            if found is None:
                out.print(f"{where}skipped: the joint check of {inst.n_robots} robots (too many joint points for the "
                          f"exact table, no pair of robots in conflict, and {why}): whether the robots can keep their "
                          "ends and budgets together is undecided; solving decides it (status infeasible)", markup=False)
                undecided += 1
                continue
            note = f" ({inst.n_robots} robots; {why})"
        if never:
            note += f" (warning: sensors {never} have no lattice point within d_th and can never upload)"
        stranded = lattice.stranded_sensors(inst) if lattice.cheap(inst) else []
        if stranded:
            note += (f" (warning: sensors {stranded} are never uploaded by any legal plan: no point in their range "
                     "can be reached and left for the end within the horizon and max_moves; their packets only age)")
        out.print(f"{where}ok{note}", markup=False)
    return 2 if bad else UNDECIDED if undecided else 0
