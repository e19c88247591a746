"""``citysynth``: the command line.

Every sub-command maps user errors (the classes of
:data:`citysynth.pipeline.errors.USER_ERRORS`: a malformed problem, a bad library, bad
GeoJSON, a failed layout check, a wrong option or city.toml) to one line on stderr and
exit code 2, with no traceback; an infeasible problem is an answer, not an error, and
exits 1 with its reason. Any other exception is a bug and keeps its traceback.
Sub-commands live in :mod:`citysynth.pipeline.commands` and register themselves here.

Starting up imports only the commands' options: each command imports what it runs
(numba, trimesh, shapely, USD: about 1.5 s) when it runs, so ``--help``, ``--version``
and a mistyped option answer at once, and ``diff`` loads no solver.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import traceback
import warnings
from collections.abc import Sequence
from importlib.metadata import PackageNotFoundError, version
from typing import NoReturn

from citysynth.export.imports import import_shielded
from citysynth.pipeline.city.process import (
    EXIT_TERMINATED,
    Terminated,
    terminate_as_interrupt,
)
from citysynth.pipeline.commands import (
    build,
    city,
    demo,
    diff,
    gallery,
    ingest,
    skeleton,
    solve,
    street,
    tower,
)
from citysynth.pipeline.compile_notice import announce_compile
from citysynth.pipeline.errors import (
    EXIT_BAD_INPUT,
    EXIT_INFEASIBLE,
    EXIT_INTERNAL,
    EXIT_OK,
    USER_ERRORS,
    environment_message,
)
from citysynth.pipeline.paths import (
    check_names_encodable,
    check_not_empty,
    check_numbers,
    check_out_dir,
)
from citysynth.skeletons import InputWarning
from citysynth.solver.interrupts import interrupt_in

__all__ = ["EXIT_BAD_INPUT", "EXIT_INFEASIBLE", "EXIT_INTERNAL", "EXIT_OK", "build_parser",
           "main"]


def _version() -> str:
    try:
        return version("citysynth")
    except PackageNotFoundError:   # running from a source tree that is not installed
        return "unknown"


# argparse's wording, said in the user's words (the option keeps its name)
_PLAIN = (
    (re.compile(r"^argument (\S+): "), r"\1: "),
    (re.compile(r"invalid int value: (.*)$"), r"\1 is not a whole number"),
    (re.compile(r"invalid float value: (.*)$"), r"\1 is not a number"),
    (re.compile(r"invalid choice: (\S+) \(choose from (.*)\)$"), r"\1 is not one of \2"),
    (re.compile(r"expected one argument$"), "needs a value"),
    (re.compile(r"expected (\d+) arguments$"), r"needs \1 values"),
    (re.compile(r"^the following arguments are required: (.*)$"), r"missing \1"),
    (re.compile(r"^COMMAND: (\S+) is not one of"), r"\1 is not a command; one of"),
    (re.compile(r"^missing COMMAND$"), "no command given"),
)


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage mistake (an unknown option, a missing or wrongly
    typed value, a bad choice) as the project reports any bad input: one line on stderr
    that says what is wrong and where to read more, exit 2. The usage block argparse
    prints first would bury that line; ``--help`` still prints it all."""

    commands: dict[str, argparse.ArgumentParser] = {}   # set on the top-level parser

    def error(self, message: str) -> NoReturn:
        for pattern, plain in _PLAIN:
            message = pattern.sub(plain, message)
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}; see {self.prog} --help\n")

    def parse_args(self, args: Sequence[str] | None = None,   # type: ignore[override]
                   namespace: argparse.Namespace | None = None) -> argparse.Namespace:
        """Words left over are blamed on the command they were given to, whose --help
        lists its options (argparse blames the top-level ``citysynth``)."""
        ns, extras = self.parse_known_args(args, namespace)
        where = self.commands.get(getattr(ns, "command", None) or "", self)
        if extras:
            unknown = "unknown option" if extras[0].startswith("-") else "unexpected argument"
            where.error(f"{unknown} {' '.join(extras)}")
        for action in where._actions:   # "" is no name: `ingest ""` said "manifest.toml:
            value = getattr(ns, action.dest, None)   # missing", of the current folder
            if isinstance(value, str) and not value.strip() and \
                    action.dest not in ("command", "out"):   # (-o: its own message)
                name = action.option_strings[-1] if action.option_strings else \
                    (action.metavar or action.dest.upper())
                where.error(f"{name}: empty ({value!r}); give a value")
        return ns


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="citysynth",
        description="Example-based city generator: exact k-best layouts of building parts.",
    )
    parser.add_argument("--version", action="version", version=f"citysynth {_version()}")
    parser.add_argument("--cache", metavar="DIR", default=None,
                        help="folder for part-database caches (default: beside a library "
                             "you may write, else the user cache folder; or "
                             "$CITYSYNTH_CACHE)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (solve, ingest, skeleton, build, tower, street, city, diff, demo, gallery):
        module.register(sub)
    parser.commands = dict(sub.choices)
    return parser


_plain_format = warnings.formatwarning


def _format_warning(message: Warning | str, category: type[Warning], filename: str,
                    lineno: int, line: str | None = None) -> str:
    """A feature left out of the input is one plain line (it names file and feature)."""
    if issubclass(category, InputWarning):
        return f"citysynth: warning: {message}\n"
    return _plain_format(message, category, filename, lineno, line)


# commands that run the solver's kernels
SOLVING = {"solve", "building", "block", "city", "demo", "tower", "street", "gallery"}
# commands that read part meshes (trimesh; solve reads problem files only)
READING_MESHES = (SOLVING - {"solve"}) | {"ingest"}
EXIT_PIPE = 141      # 128 + SIGPIPE, as a Unix tool killed by the closed pipe ends
EXIT_INTERRUPTED = 130   # 128 + SIGINT


def main(argv: list[str] | None = None) -> int:
    """Run one command; its exit code. A reader that closed the pipe (``| head -1``)
    ends the command quietly, --help and usage errors included."""
    try:
        try:
            code = _run(argv)
        finally:
            sys.stdout.flush()    # a closed pipe shows here, not at interpreter exit
    except BrokenPipeError:
        return _closed_pipe()
    if argv is None and code in (EXIT_INTERRUPTED, EXIT_TERMINATED):
        # the program itself, stopped: leave now, not after a second of tearing down
        # the loaded libraries (everything is written or swept; stdio is flushed)
        sys.stderr.flush()
        os._exit(code)
    return code


def _run(argv: list[str] | None) -> int:
    warnings.formatwarning = _format_warning
    for stream in (sys.stdout, sys.stderr):   # a Latin-1 terminal: "≤" as "?", not a
        encoding = (getattr(stream, "encoding", None) or "utf-8").lower()   # crash
        if encoding.replace("-", "") != "utf8" and hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="replace")   # after the work is written
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as stop:     # --help, --version (0) or a usage mistake (2)
        return stop.code if isinstance(stop.code, int) else EXIT_BAD_INPUT
    try:
        if args.cache is not None:   # the environment carries it into worker processes
            from citysynth.parts_db.library import CACHE_ENV

            check_not_empty(args.cache, "--cache")
            os.environ[CACHE_ENV] = os.path.abspath(args.cache)
        check_numbers(args)
        check_names_encodable(args)
        if getattr(args, "out", None) is not None:
            check_out_dir(args.out)
        if args.command in SOLVING - {"city"}:   # a city says it once its inputs are read
            announce_compile()
        with terminate_as_interrupt():   # SIGTERM anywhere in a command: exit 143
            if args.command in READING_MESHES:   # Ctrl-C in trimesh's import was
                import_shielded("trimesh")        # swallowed (see export.imports)
            return int(args.run(args))
    except USER_ERRORS as exc:
        print(f"citysynth {args.command}: error: {_cut(str(exc))}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as exc:
        return _stopped(exc)
    except OSError as exc:
        if isinstance(exc, BrokenPipeError):
            raise
        if exc.errno is None:
            return _internal(args.command)
        print(f"citysynth {args.command}: error: {environment_message(exc)}",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception as exc:   # a bug: its own exit code, so a pipeline never reads
        signal = interrupt_in(exc)   # "infeasible"; or a signal numba's dispatcher wrapped
        return _internal(args.command) if signal is None else _stopped(signal)


MESSAGE_MOST = 2000   # characters of one error line


def _cut(text: str) -> str:
    """An error message cut to :data:`MESSAGE_MOST` characters: a value from a file is
    quoted short where a message is made (``shown``), but one message that quoted a
    10 MB city.toml string whole wrote 10 MB to stderr; none can now."""
    if len(text) <= MESSAGE_MOST:
        return text
    return f"{text[:MESSAGE_MOST - 40]}... (cut: {len(text):,} characters in all)"


def _stopped(exc: KeyboardInterrupt) -> int:
    """Stopped by Ctrl-C (exit 130) or SIGTERM (143): one line saying which."""
    terminated = isinstance(exc, Terminated)
    print(f"citysynth: {'terminated' if terminated else 'interrupted'}", file=sys.stderr)
    return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED


def _internal(command: str) -> int:
    """A bug met: its traceback and a line saying so on stderr, exit 3 (never 1, which
    means "no layout exists")."""
    traceback.print_exc()
    print(f"citysynth {command}: internal error (a bug, not your input); please report "
          "it with the traceback above", file=sys.stderr)
    return EXIT_INTERNAL


def _closed_pipe() -> int:
    """The reader went away (``citysynth diff A B | head -1``): end quietly. Whatever
    is still buffered for stdout goes to /dev/null, so the interpreter's own flush at
    exit does not raise again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):   # stdout is not a real file (captured in tests)
        pass
    return EXIT_PIPE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
