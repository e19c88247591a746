"""``citysynth``: the command line.

Every sub-command maps user errors (the classes of
:data:`citysynth.pipeline.errors.USER_ERRORS`: a malformed problem, a bad library, bad
GeoJSON, a failed layout check, a wrong option or city.toml) to one line on stderr and
exit code 2, with no traceback; an infeasible problem is an answer, not an error, and
exits 1 with its reason. Any other exception is a bug and keeps its traceback.
Sub-commands live in :mod:`citysynth.pipeline.commands` and register themselves here.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from importlib.metadata import PackageNotFoundError, version

from citysynth.parts_db.library import CACHE_ENV
from citysynth.pipeline.commands import build, city, demo, diff, ingest, skeleton, solve, tower
from citysynth.pipeline.errors import (
    EXIT_BAD_INPUT,
    EXIT_INFEASIBLE,
    EXIT_INTERNAL,
    EXIT_OK,
    USER_ERRORS,
)
from citysynth.skeletons import InputWarning

__all__ = ["EXIT_BAD_INPUT", "EXIT_INFEASIBLE", "EXIT_INTERNAL", "EXIT_OK", "build_parser",
           "main"]


def _version() -> str:
    try:
        return version("citysynth")
    except PackageNotFoundError:   # running from a source tree that is not installed
        return "unknown"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="citysynth",
        description="Example-based city generator: exact k-best layouts of building parts.",
    )
    parser.add_argument("--version", action="version", version=f"citysynth {_version()}")
    parser.add_argument("--cache", metavar="DIR", default=None,
                        help="folder for part-database caches (default: beside a library "
                             "you may write, else the user cache folder; or "
                             "$CITYSYNTH_CACHE)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (solve, ingest, skeleton, build, tower, city, diff, demo):
        module.register(sub)
    return parser


_plain_format = warnings.formatwarning


def _format_warning(message: Warning | str, category: type[Warning], filename: str,
                    lineno: int, line: str | None = None) -> str:
    """A feature left out of the input is one plain line (it names file and feature)."""
    if issubclass(category, InputWarning):
        return f"citysynth: warning: {message}\n"
    return _plain_format(message, category, filename, lineno, line)


def main(argv: list[str] | None = None) -> int:
    warnings.formatwarning = _format_warning
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.cache:   # the environment carries it into worker processes too
        os.environ[CACHE_ENV] = os.path.abspath(args.cache)
    try:
        return int(args.run(args))
    except USER_ERRORS as exc:
        print(f"citysynth {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("citysynth: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
