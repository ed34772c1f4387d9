"""The ``voiopt`` command. Thin: it parses arguments and calls the API; errors are one line, exit 2."""

from __future__ import annotations

import argparse
import gc
import json
import signal
import sys
import warnings
from pathlib import Path

from rich.console import Console
from rich.table import Table

import voiopt
from voiopt.cli import lossy as cli_lossy
from voiopt.cli import policy as cli_policy
from voiopt.cli.arguments import Parser, at_least, count
from voiopt.cli.bench import add_commands as add_bench_commands
from voiopt.cli.output import one_line_warning, pipe_closed
from voiopt.cli.validate import cmd_validate
from voiopt.cli.view import add_commands as add_view_commands
from voiopt.core import instance as instance_mod
from voiopt.core.instance import show
from voiopt.core.plan import plan_of
from voiopt.core.result import disagreement
from voiopt.errors import OptionError, PlanError, VoioptError, WorkerDied
from voiopt.grid import lattice
from voiopt.mdp.robot import REWARD_UNITS
from voiopt.networks import fields
from voiopt.networks.generate import MAX_COUNT, PRESETS, generate_set, write_one, write_set
from voiopt.networks.generate import generate as generate_one
from voiopt.objectives import DEFAULT, OBJECTIVES
from voiopt.runtime import numba_start
from voiopt.runtime.files import check_output_dir, check_output_file, dumps_json, read_json
from voiopt.runtime.status import Status
from voiopt.runtime.stop import last_signal, sigterm_raises
from voiopt.solvers import UnknownOption
from voiopt.solvers.base import DEFAULT_MEMORY_GB

out = Console(highlight=False, soft_wrap=True)
err = Console(stderr=True, highlight=False, soft_wrap=True)


_seed, _positive = at_least(0), at_least(1)


def _metrics_table(rows: dict[str, dict[str, float]], title: str = "", first: str = "plan") -> Table:
    table = Table(title=title or None)
    table.add_column(first)
    for m in OBJECTIVES:
        table.add_column(m, justify="right")
    for name, metrics in rows.items():
        table.add_row(name, *(f"{metrics[m]:.6g}" if m in metrics else "-" for m in OBJECTIVES))
    return table


# ------------------------------------------------------------------------------- commands


def _note_stranded(insts) -> None:
    """A note, on stderr, when a generated network has sensors that no legal plan uploads."""
    hit = [inst.name for inst in insts if lattice.cheap(inst) and lattice.stranded_sensors(inst)]
    if hit:
        err.print(f"note: {len(hit)} of {len(insts)} network(s) ({', '.join(hit[:3])}{', ...' if len(hit) > 3 else ''}) "
                  "have sensors that no legal plan can upload (the horizon, the way to the end or --max-moves "
                  "too short): voiopt validate names them", markup=False)


def cmd_evaluate(args) -> int:
    inst = instance_mod.load(args.instance)
    d = read_json(args.plan, error=PlanError)
    plan = plan_of(d, args.plan, inst.name)
    try:
        metrics = cli_lossy.metrics(inst, plan)
    except PlanError as e:  # the plan breaks a rule of this instance: name the plan's file
        raise PlanError(f"{args.plan}: {e}") from None
    differ = None
    if isinstance(d, dict) and "plan" in d:  # a result (or a submission): its own metrics and value
        differ = disagreement(d.get("metrics"), metrics) or (
            disagreement({d["objective"]: d.get("value")}, metrics) if d.get("objective") in OBJECTIVES
            and d.get("value") is not None else None)
    if differ:  # a result's own metrics: solved on another instance, or edited
        err.print(f"note: {args.plan} says otherwise ({differ}): it was solved on another instance than "
                  f"{args.instance}, or edited", markup=False)
    if args.json:
        print(json.dumps(cli_lossy.evaluation_json(inst, metrics), indent=2))
    else:
        out.print(_metrics_table({Path(args.plan).name: metrics}, title=cli_lossy.title(inst)))
    return 0


def _generate_options(args) -> dict:
    """The generator's keyword options: the paper's networks, or a preset's."""
    end = None if args.end is None else fields.parse_end(args.end)
    if args.preset == "factory":
        given = [flag for flag, v in (("--width", args.width), ("--height", args.height), ("--step", args.step),
                                      ("--rho", args.rho), ("--power", args.power), ("--initial-aoi", args.initial_aoi),
                                      ("--blocked-fraction", args.blocked_fraction), ("--end", args.end), ("--dock", args.dock or None))
                 if v is not None]
        if given:
            raise OptionError(f"{given[0]}: the factory preset fixes the floor, racks, dock and sensors; it takes "
                              "--sensors, --horizon, --max-moves and --robots")
        return dict(n_sensors=args.sensors, horizon=args.horizon or fields.FACTORY_HORIZON,
                    max_moves=fields.FACTORY_MAX_MOVES if args.max_moves is None else args.max_moves,
                    robots=args.robots, links=args.links)
    if args.dock and args.robots < 2:
        raise OptionError(f"--dock: starts the robots around robot 0's start; give --robots K with K >= 2 "
                          f"(got --robots {args.robots})")
    pick = lambda v, default: default if v is None else v  # noqa: E731
    return dict(
        n_sensors=pick(args.sensors, 4), horizon=pick(args.horizon, 30), width=pick(args.width, 5.0),
        height=pick(args.height, 5.0), step=pick(args.step, 1.0), rho=tuple(pick(args.rho, [0.0, 1.0])),
        power_w=pick(args.power, 1.0), initial_aoi=tuple(pick(args.initial_aoi, [1, 1])),
        blocked_fraction=pick(args.blocked_fraction, 0.0), end=end, max_moves=args.max_moves,
        robots=args.robots, dock=args.dock, links=args.links,
    )


def cmd_generate(args) -> int:
    kwargs = _generate_options(args)
    one_file = args.out is not None and args.out.endswith(".json") and not Path(args.out).is_dir()
    if args.out is None or one_file:
        if args.count != 1:
            raise OptionError(f"--count: {args.count} networks need --out DIR, a folder"
                              + (f", not the file {args.out!r}" if one_file else ""))
        maker = fields.factory if args.preset == "factory" else generate_one
        inst = maker(seed=args.seed, name=args.name, **kwargs)
        if one_file:
            write_one(inst, args.out, overwrite=args.overwrite)
            out.print(f"wrote {inst.name} to {args.out}", markup=False)
        else:
            print(json.dumps(inst.to_dict(), indent=2))
        _note_stranded([inst])
        return 0
    check_output_dir(args.out, "--out")
    if args.count > MAX_COUNT:
        raise OptionError(f"--count: at most {MAX_COUNT} networks in one set, got {args.count}")
    insts = generate_set(args.count, seed=args.seed, preset=args.preset, name=args.name, **kwargs)
    paths = write_set(insts, args.out, overwrite=args.overwrite)
    out.print(f"wrote {len(paths)} instance(s) to {args.out}", markup=False)
    _note_stranded(insts)
    return 0


SOLVE_FLAGS = ("time_limit", "gap", "threads", "episodes", "seed", "memory_limit", "reward_units", "warm_start",
               "verbose", *cli_policy.POLICY_OPTIONS)  # solve's flags, by the keyword each gives


def _solve_options(args, inst) -> dict:
    opts = {}
    for key in (*SOLVE_FLAGS[:7], *cli_policy.POLICY_OPTIONS):
        v = getattr(args, key, None)
        if v is not None:
            opts[key] = v
    if args.warm_start is not None:  # no plan of this instance, or one that breaks a rule of it: say which option and file
        where = ""  # load_plan's own messages name the file; evaluate's do not
        try:
            opts["warm_start"] = voiopt.load_plan(args.warm_start, inst.name)
            where = f"{args.warm_start}: "
            voiopt.evaluate(inst, opts["warm_start"])
        except PlanError as e:
            raise PlanError(f"--warm-start: {where}{e}") from None
    if not args.quiet and not args.json:
        opts["progress"] = True
    if args.verbose:
        opts["verbose"] = True  # only milp takes it: elsewhere a one-line error says so
    return opts


def cmd_solve(args) -> int:
    if args.quiet and args.verbose:
        raise OptionError("--quiet, --verbose: give one or neither (--quiet prints nothing but errors)")
    if args.output is not None:  # before the work, not after it
        check_output_file(args.output, inputs=[("INSTANCE", args.instance), ("--warm-start", args.warm_start)])
    policy_out = cli_policy.policy_path(args)  # checked before the work too
    inst = instance_mod.load(args.instance)
    try:
        result = voiopt.solve(inst, method=args.method, objective=args.objective, **_solve_options(args, inst))
    except UnknownOption as e:  # the command line's flags, not Python's keywords
        flag = {k: f"--{k.replace('_', '-')}" for k in (*SOLVE_FLAGS, e.key)}
        raise OptionError(f"{flag[e.key]}: not an option of method {e.method!r} (on the command line it takes "
                          f"{', '.join(flag[k] for k in e.takes if k in flag) or 'none of its options'})") from None
    result = cli_policy.save_policy(policy_out, result)
    if (note := cli_policy.policy_note(policy_out, result)) and not args.quiet:
        err.print(note, markup=False)
    if args.output:
        result.save(args.output)
    if args.json:
        print(dumps_json(result.to_dict()))
    elif not args.quiet:
        out.print(result.summary(), markup=False)
        if result.metrics:
            out.print(_metrics_table({result.method: result.metrics}, cli_lossy.solve_title(inst, result), "method"))
        if result.solver.get("note") or not result.metrics:
            out.print(f"{'note' if result.metrics else 'no plan'}: {result.solver.get('note', '')}".rstrip(": "),
                      markup=False)
        if args.output:
            out.print(f"result written to {args.output}", markup=False)
    if result.status == Status.INTERRUPTED:  # the best plan is kept (and written), but the run did not finish
        kept = (f"written to {args.output}" if args.output else "printed above (--json)" if args.json
                else "not kept (-o FILE keeps it)")
        err.print(f"voiopt: {result.solver.get('stopped', 'interrupted')}; the best plan so far is {kept}",
                  markup=False)
        return 128 + (last_signal() or signal.SIGINT)
    nothing = result.plan is None and getattr(result, "policy", None) is None  # stopped before any plan
    return 1 if result.status == Status.ERROR or nothing and Status(result.status).stopped else 0


def cmd_export(args) -> int:
    from voiopt.solvers.milp.export import export

    check_output_file(args.model, "MODEL", inputs=[("INSTANCE", args.instance)])
    inst = instance_mod.load(args.instance)
    export(inst, args.objective, args.model, covering_level=args.covering_level)
    out.print(f"wrote {args.model}", markup=False)
    return 0


def cmd_gap_report(args) -> int:
    from voiopt.experiments.gaps import gap_report

    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    notes: list[str] = []
    gap_report(
        args.instances, methods, args.objective, args.output, time_limit=args.time_limit,
        memory_limit=args.memory_limit, episodes=args.episodes, seed=args.seed, seeds=args.seeds,
        reward_units=args.reward_units, workers=args.workers, dask_scheduler=args.dask_scheduler,
        progress=not args.quiet, notes=notes, samples=args.samples, ir_samples=args.ir_samples,
    )
    for note in notes:
        err.print(note, markup=False)
    if not args.quiet:
        md = (Path(args.output) / "summary.md").read_text(encoding="utf-8")
        out.print(md.split("![")[0].rstrip(), markup=False)
        out.print(f"written: {Path(args.output) / 'gaps.csv'}, summary.md, gaps.png, results/", markup=False)
    return 0


def cmd_figures(args) -> int:
    from voiopt.experiments.paper import make_figures

    files = make_figures(
        args.out, networks=args.networks, robot_networks=args.robot_networks, episodes=args.episodes,
        time_limit=args.time_limit, memory_limit=args.memory_limit,
        seed=args.seed, seeds=args.seeds, reward_units=args.reward_units, workers=args.workers, dask_scheduler=args.dask_scheduler, progress=not args.quiet,
    )
    if not args.quiet:
        out.print("\n".join(str(f) for f in files), markup=False)
    return 0


def cmd_plot(args) -> int:
    from voiopt.experiments.plots import check_figure_path, instance_for, plot_plan, plot_result

    check_figure_path(args.output)
    check_output_file(args.output, inputs=[("RESULT", args.result), ("--instance", args.instance)])
    d = read_json(args.result, error=VoioptError)
    if not isinstance(d, dict) or "status" in d:  # a result of voiopt solve (or not an object: said so)
        result = voiopt.load_result(args.result)
        inst, where = instance_for(result.instance, args.instance, args.result)
        draw = lambda: plot_result(result, inst, args.output, where)  # noqa: E731
    else:  # a plan, or a plan with instance and objective (a VoI-Lib submission)
        plan = plan_of(d, args.result)  # its errors name the file
        name = d.get("instance") if isinstance(d.get("instance"), str) else None
        objective = d.get("objective", DEFAULT)
        if objective not in OBJECTIVES:
            raise OptionError(f"{args.result}: objective: must be one of {', '.join(OBJECTIVES)}, got {show(objective)}")
        inst = instance_for(name, args.instance, args.result, "plan")[0]
        draw = lambda: plot_plan(inst, plan, args.output, Path(args.result).name, objective)  # noqa: E731
    try:
        draw()
    except PlanError as e:  # the plan breaks a rule of its instance: name the file
        raise PlanError(f"{args.result}: {e}") from None
    out.print(f"wrote {args.output}", markup=False)
    return 0


def cmd_demo(args) -> int:
    from voiopt.experiments.demo import run_demo

    return run_demo(args.instance, out)


# ---------------------------------------------------------------------------------- parser


def _command(sub, name: str, help: str, func) -> argparse.ArgumentParser:
    s = sub.add_parser(name, help=help)
    s.set_defaults(func=func)
    return s


def _add_executor_options(s: argparse.ArgumentParser) -> None:
    s.add_argument("--memory-limit", type=float, default=DEFAULT_MEMORY_GB, metavar="GB",
                   help=f"per run (default {DEFAULT_MEMORY_GB:g})")
    s.add_argument("--workers", type=int, default=1, metavar="K", help="parallel processes (default 1)")
    s.add_argument("--dask-scheduler", default=None, metavar="ADDRESS",
                   help="tcp://HOST:PORT of a Dask cluster, or 'local' for a LocalCluster (needs voiopt[dask])")


def _add_qlearning_options(s: argparse.ArgumentParser, seeds: bool) -> None:
    s.add_argument("--episodes", type=_positive, default=None, metavar="N",
                   help="Q-learning episodes R_max, at most 1e12; 1e6 is accepted (default 1000000, the paper's)")
    s.add_argument("--reward-units", default=None if not seeds else "bit/s", choices=list(REWARD_UNITS),
                   help="Q-learning reward: V in bit/s as the paper writes it, or V/B; idle penalty 100 either way "
                        "(default bit/s)")
    if seeds:
        s.add_argument("--seed", type=_seed, default=0, metavar="S", help="first seed (default 0)")
        s.add_argument("--seeds", type=_positive, default=3, metavar="K",
                       help="randomised methods run with seeds S .. S+K-1 (default 3)")


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="voiopt", description="Certified path planning and scheduling for VoI data collection.")
    p.add_argument("--version", action="version", version=f"voiopt {voiopt.__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser)

    s = _command(sub, "validate", "check instance files; print ok or the errors", cmd_validate)
    s.add_argument("instances", nargs="+", metavar="INSTANCE", help="instance JSON files")

    s = _command(sub, "evaluate", "simulate a plan and print its four metrics", cmd_evaluate)
    s.add_argument("instance", metavar="INSTANCE", help="an instance JSON file")
    s.add_argument("plan", metavar="PLAN", help="a plan object or a whole result JSON")
    s.add_argument("--json", action="store_true", help="print a JSON object with key 'metrics'")

    s = _command(sub, "generate", "random networks with the paper's distributions, or factory floors", cmd_generate)
    s.add_argument("--preset", choices=PRESETS, default=None,
                   help="factory: a 20 x 20 m floor with racks, the dock at (0, 0) as start and end, 10-30 sensors "
                        "(or --sensors), T = 100 (or --horizon), max_moves 80 (or --max-moves)")
    s.add_argument("--sensors", type=int, default=None, help="N (default 4)")
    s.add_argument("--horizon", type=int, default=None, help="T (default 30)")
    s.add_argument("--width", type=float, default=None, help="metres (default 5)")
    s.add_argument("--height", type=float, default=None, help="metres (default 5)")
    s.add_argument("--step", type=float, default=None, help="metres (default 1)")
    s.add_argument("--rho", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="rho ~ U(LO, HI) (default 0 1)")
    s.add_argument("--power", type=float, default=None, help="P in watts (default 1)")
    s.add_argument("--initial-aoi", type=int, nargs=2, default=None, metavar=("LO", "HI"), help="(default 1 1)")
    s.add_argument("--blocked-fraction", type=float, default=None, metavar="F",
                   help="block this fraction of the lattice points at random, keeping the free ones connected "
                        "(default 0)")
    s.add_argument("--end", default=None, metavar="start|random|X,Y",
                   help="the point of the last slot: the start, a random reachable point, or X,Y (default: none)")
    s.add_argument("--max-moves", type=int, default=None, metavar="K",
                   help="at most K slots with a move (default: no budget)")
    s.add_argument("--robots", type=int, default=1, metavar="K",
                   help="K robots (MODEL.md section 10) with distinct starts (default 1); the factory preset puts "
                        "them at the free points nearest the dock")
    cli_lossy.add_links_option(s)
    s.add_argument("--dock", action="store_true",
                   help="with --robots: start the robots at the free points nearest robot 0's start")
    s.add_argument("--seed", type=_seed, default=0, help="the networks depend on it alone (default 0)")
    s.add_argument("--count", type=_positive, default=1, help=f"how many networks, at most {MAX_COUNT}; more than one needs --out (default 1)")
    s.add_argument("--name", default=None,
                   help="name of the instance, or prefix of a set's (-000, -001, ... follow); default nN-tT-seedS, "
                        "and for the factory preset factory-nN-tT-seedS alone, factory-seedS in a set")
    s.add_argument("--out", default=None, metavar="DIR", help="write files in this folder (else print one to stdout); "
                   "with --count 1, a path ending in .json is the file itself")
    s.add_argument("--overwrite", action="store_true",
                   help="replace files in --out that hold other instances (default: refuse, write nothing)")

    s = sub.add_parser("solve", help="solve an instance and write the result JSON")
    s.add_argument("instance", metavar="INSTANCE", help="an instance JSON file")
    s.add_argument("--method", default=None, help=f"one of {', '.join(voiopt.METHODS)} (default dp, the fastest exact "
                   "method; milp for three robots or more)")
    s.add_argument("--objective", default=DEFAULT, choices=list(OBJECTIVES), help="(default mean-min-voi)")
    s.add_argument("--time-limit", type=float, default=None, metavar="S", help="seconds (default: none)")
    s.add_argument("--gap", type=float, default=None, metavar="G", help="milp: relative MIP gap (default 0: exact)")
    s.add_argument("--threads", type=count, default=None, metavar="K", help="milp: HiGHS threads (default: HiGHS's); dp: chunks of a slot "
                   "expanded at once, the same plan sooner on K cores (default 1)")
    _add_qlearning_options(s, seeds=False)
    s.add_argument("--seed", type=_seed, default=None, metavar="S",
                   help="seed of a randomised method (default 0)")
    s.add_argument("--memory-limit", type=float, default=None, metavar="GB",
                   help=f"stop with the best plan when the method's memory passes this (default {DEFAULT_MEMORY_GB:g})")
    s.add_argument("--warm-start", default=None, metavar="PLAN", help="milp, dp: a plan or result JSON to start from")
    s.add_argument("-o", "--output", default=None, metavar="RESULT", help="write the result JSON here")
    s.add_argument("--json", action="store_true", help="print the result JSON to stdout")
    s.add_argument("--quiet", action="store_true", help="print nothing but errors")
    s.add_argument("--verbose", action="store_true", help="milp: show HiGHS's own log on stderr")
    cli_policy.add_policy_option(s).set_defaults(func=cmd_solve)

    s = _command(sub, "export", "write the MILP of an instance as MPS or LP (by extension; min-voi's objective is "
                 "ln of the min VoI, see the file's comments)", cmd_export)
    s.add_argument("instance", metavar="INSTANCE", help="an instance JSON file")
    s.add_argument("model", metavar="MODEL", help="output file, .mps or .lp")
    s.add_argument("--objective", default=DEFAULT, choices=list(OBJECTIVES), help="(default mean-min-voi)")
    s.add_argument("--covering-level", type=int, default=None, metavar="K",
                   help="min-voi, max-aoi: write the bisection's covering problem for the K-th smallest candidate "
                        "worth instead (0-based; default: the objective's own MILP)")

    s = _command(sub, "gap-report", "proven optimality gaps of several methods over many networks", cmd_gap_report)
    s.add_argument("instances", nargs="+", metavar="INSTANCES", help="instance files or folders of them")
    s.add_argument("--methods", default="dp,qlearning,aoi-qlearning,shortest-path",
                   help="comma-separated (default dp,qlearning,aoi-qlearning,shortest-path)")
    s.add_argument("--objective", default=DEFAULT, choices=list(OBJECTIVES), help="(default mean-min-voi)")
    s.add_argument("--time-limit", type=float, default=None, metavar="S", help="per run (default: none)")
    _add_qlearning_options(s, seeds=True)
    _add_executor_options(s)
    s.add_argument("--samples", type=int, default=None, metavar="K",
                   help="replan, qlearning on lossy links: coupled scenarios of a Monte Carlo value (default 1000)")
    s.add_argument("--ir-samples", type=int, default=None, metavar="K",
                   help="replan, qlearning on lossy links: scenarios of the information-relaxation bound, a "
                        "statistical bound reported apart from the proven ones (default 0: none)")
    s.add_argument("-o", "--output", "--out", dest="output", required=True, metavar="DIR",
                   help="gaps.csv, summary.md, gaps.png and results/ (one JSON per run) go here; a re-run resumes "
                        "(--out, as for figures and generate, says the same)")
    s.add_argument("--quiet", action="store_true", help="print nothing but errors (the files are written all the same)")

    s = _command(sub, "figures", "reproduce the paper's figures with the proven optimum", cmd_figures)
    s.add_argument("--out", required=True, metavar="DIR",
                   help="the figures (PNG and CSV), figures.md and results/ go here; a re-run resumes")
    s.add_argument("--networks", type=int, default=40, help="networks per setting (default 40)")
    s.add_argument("--robot-networks", type=int, default=10, metavar="N",
                   help="networks per number of robots in Fig. 8 (default 10: joint Q-learning is slow)")
    s.add_argument("--time-limit", type=float, default=60.0, metavar="S",
                   help="dp limit per network, and milp's in Fig. 8 (default 60)")
    _add_qlearning_options(s, seeds=True)
    _add_executor_options(s)
    s.add_argument("--quiet", action="store_true", help="print nothing but errors (the files are written all the same)")

    s = _command(sub, "plot", "draw the trajectory of a result or a plan", cmd_plot)
    s.add_argument("result", metavar="RESULT", help="a result JSON (voiopt solve -o), or a plan JSON (with --instance, "
                                                    "unless it names its instance)")
    s.add_argument("--instance", default=None, metavar="INSTANCE", help="default: NAME.json beside the result, in instances/ beside it, in the folder above it, or in ./instances")
    s.add_argument("-o", "--output", required=True, metavar="PNG", help="the image to write")

    s = _command(sub, "methods", "list the solution methods", lambda a: (out.print("\n".join(voiopt.METHODS), markup=False), 0)[1])

    s = _command(sub, "demo", "run the main job on the shipped case study", cmd_demo)
    s.add_argument("instance", nargs="?", default=None, metavar="INSTANCE",
                   help="(default: the shipped case study, instances/case-study.json)")

    add_bench_commands(sub, _command, _add_executor_options, count)
    add_view_commands(sub, _command)
    return p


def main(argv: list[str] | None = None) -> int:
    args = None
    warnings.showwarning = one_line_warning
    try:
        args = build_parser().parse_args(argv)
        with sigterm_raises():  # a SIGTERM ends any command with a line, as a Ctrl-C does
            return int(args.func(args) or 0)
    except VoioptError as e:
        err.print(f"voiopt: error: {e}", markup=False)
        return 2
    except BrokenPipeError:  # stdout's reader has gone (voiopt generate | head -1): nothing more to say
        return pipe_closed()
    except (WorkerDied, OSError) as e:  # a worker killed; a disk full or gone after the checks
        err.print(f"voiopt: error: {e}", markup=False)
        return 1
    except KeyboardInterrupt as e:  # a sweep stopped as a whole, or a second Ctrl-C
        code = getattr(e, "exit_code", 128 + (last_signal() or signal.SIGINT))
        sweep = args is not None and (args.command in ("gap-report", "figures", "demo")
                                      or getattr(args, "bench_command", "") == "certify")
        kept = "finished results are kept" if sweep else "the command did not finish"
        err.print(f"voiopt: interrupted ({signal.Signals(code - 128).name}); {kept}", markup=False)
        return code


def run() -> None:
    """One command, then exit (the console script and ``python -m voiopt`` call it, through
    voiopt.__main__, which catches a Ctrl-C while this module imports).

    A ``solve`` runs without Python's cyclic garbage collector: importing numba and loading its
    cached kernels build a large graph of long-lived objects, which collections would walk again
    and again (about 0.2 s of start-up), and one solve leaves next to no cyclic garbage (100 to
    2400 objects, measured on the case study). Sweeps keep the collector. Whatever is alive at
    exit is frozen rather than walked once more on the way out (about 0.4 s). numba starts
    without its BLAS check (voiopt.runtime.numba_start, 0.2 to 0.3 s)."""
    numba_start.QUICK = True  # numba starts without its BLAS check: voiopt's kernels need none
    if sys.argv[1:2] == ["solve"]:
        gc.disable()
    try:
        code = main()
        sys.stdout.flush()  # a closed pipe shows here, not in the flush at exit
    except BrokenPipeError:
        code = pipe_closed()
    finally:
        gc.freeze()
    sys.exit(code)


if __name__ == "__main__":
    run()
