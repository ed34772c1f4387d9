"""The ``voiopt`` command's entry: the console script and ``python -m voiopt`` both run ``run``.

Python takes about a third of a second to import the command line (numpy, rich, voiopt's
modules). A Ctrl-C in that time used to end the command with Python's traceback of the import
it fell in. Nothing has been done or written by then, so it ends in one line, with the exit
status of Ctrl-C (130). ``import voiopt`` is light (PEP 562), so this module runs before the
heavy imports. Once imported, the command handles signals itself (voiopt.cli.main, voiopt.runtime.stop). A
SIGTERM in that time ends the process as SIGTERM does by default: no output, and status 143 in
a shell."""

from __future__ import annotations

import signal
import sys


def run() -> None:
    try:
        from voiopt.cli import main as cli
    except KeyboardInterrupt:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C changes nothing now
        sys.stderr.write("voiopt: interrupted (SIGINT) while starting; nothing was done\n")
        raise SystemExit(128 + signal.SIGINT) from None
    cli.run()


if __name__ == "__main__":
    run()
