"""The ``bnerr`` command line.

Subcommands live one per module in :mod:`benchmarks.commands`; each module defines
``register(subparsers)`` that adds its parser and sets ``func`` (called with the parsed args,
returning an exit code). They are discovered here, so adding a command touches no other file.
The CLI lives in :mod:`benchmarks` because it is the top of the import graph: ``bnerr render``
and ``bnerr train`` need the renderer, which :mod:`bnerr` must not import.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from bnerr.errors import BnerrError

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    import benchmarks.commands as commands

    parser = argparse.ArgumentParser(
        prog="bnerr",
        description=(
            "Measure how much distributing Monte Carlo error as blue noise in screen space "
            "lowers the error after denoising, and what it costs."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if not info.name.startswith("_"):
            importlib.import_module(f"{commands.__name__}.{info.name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except BnerrError as err:
        print(f"bnerr {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
