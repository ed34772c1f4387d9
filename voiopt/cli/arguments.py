"""The command line's argument types and its parser, whose errors are one line with exit status 2."""

from __future__ import annotations

import argparse

from rich.console import Console

_err = Console(stderr=True, highlight=False, soft_wrap=True)


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse prints usage too)
        if message.startswith("the following arguments are required: command"):
            commands = next(a for a in self._actions if isinstance(a, argparse._SubParsersAction)).choices
            message = f"give a command: {', '.join(commands)} (voiopt COMMAND --help for each)"
        _err.print(f"{self.prog}: error: {message}", markup=False)
        raise SystemExit(2)


def count(text: str) -> int:
    """An integer option that also takes integer-valued numbers such as 1e6 (an integer as
    written is kept exact, however large)."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if not value.is_integer():
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}")
    return int(value)


def at_least(low: int):
    """An integer option of at least ``low`` (1e6 is accepted): a seed (0), a count (1)."""
    def parse(text: str) -> int:
        value = count(text)
        if value < low:
            raise argparse.ArgumentTypeError(f"must be an integer >= {low}, got {text!r}")
        return value
    return parse
