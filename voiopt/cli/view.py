"""The viewer's commands: ``voiopt show`` (the HTML page) and ``voiopt plot --animate`` (a GIF
or MP4, one frame a slot). Thin, as cli.py: they parse and call voiopt.viewer."""

from __future__ import annotations

from rich.console import Console

from voiopt.runtime.files import check_output_file

out = Console(highlight=False, soft_wrap=True)


def _seed(text: str) -> int:
    import argparse

    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}")
    return value


def cmd_show(args) -> int:
    from voiopt.viewer.show import default_output, run

    output = args.output if args.output is not None else default_output(args.results[0])
    check_output_file(output, inputs=[("RESULT", r) for r in args.results] + [("--instance", args.instance)])
    written = run(args.results, output, args.instance, args.seed)
    out.print(f"wrote {written}", markup=False)
    return 0


def cmd_animate(args) -> int:
    from voiopt.viewer.animate import animate, check_movie_path
    from voiopt.viewer.show import gather

    check_movie_path(args.output)
    check_output_file(args.output, inputs=[("RESULT", args.result), ("--instance", args.instance)])
    instance, (entry,), where = gather([args.result], args.instance)
    animate(instance, entry, args.output, where, fps=args.fps)
    out.print(f"wrote {args.output}", markup=False)
    return 0


def add_commands(sub, command) -> None:
    """``show``, and ``--animate`` (with ``--fps``) on the ``plot`` command already made."""
    s = command(sub, "show", "one self-contained HTML page: results or plans on one instance, with a timeline",
                cmd_show)
    s.add_argument("results", nargs="+", metavar="RESULT",
                   help="result JSONs (voiopt solve -o) or plan JSONs, all for one instance; shown side by side")
    s.add_argument("--instance", default=None, metavar="INSTANCE",
                   help="default: NAME.json beside the first result, in instances/ beside it, in the folder above it, "
                        "or in ./instances")
    s.add_argument("-o", "--output", default=None, metavar="HTML",
                   help="the page to write (default: the first file's name with .html, in this folder)")
    s.add_argument("--seed", type=_seed, default=0, metavar="S",
                   help="lossy links: the seed of the sampled run shown (default 0)")

    plot = sub.choices["plot"]
    plot.add_argument("--animate", action="store_true",
                      help="write an animation, one frame a slot: -o OUT.gif (Pillow) or OUT.mp4 (needs ffmpeg)")
    plot.add_argument("--fps", type=float, default=4.0, metavar="F", help="--animate: frames a second (default 4)")
    draw = plot.get_default("func")
    plot.set_defaults(func=lambda args: cmd_animate(args) if args.animate else draw(args))
