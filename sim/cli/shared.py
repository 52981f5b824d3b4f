"""What every ``k37`` command shares: exit codes, signals, output checks, error lines."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import NoReturn

__all__ = ["EXIT_INTERRUPTED", "EXIT_OUTPUT", "EXIT_USAGE", "Parser", "check", "interrupted",
           "positive_int", "print_error", "signals_interrupt", "stdout", "stopped"]


#: Exit code of a bad argument, job or input (one ``k37: error:`` line says which).
EXIT_USAGE = 2
#: Exit code of a command whose work is done but one of whose outputs (a file, stdout) could
#: not be written: the others are written, and an error line names the one that is not.
EXIT_OUTPUT = 3
#: Exit code of a command stopped by Ctrl-C (128 + SIGINT, as a shell reports it); a
#: command stopped by SIGTERM exits 128 + SIGTERM = 143.
EXIT_INTERRUPTED = 130


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line naming the command (``k37 run: error:
    argument --max-cycles: ...``), exit code :data:`EXIT_USAGE`, instead of the usage text.
    The top level's :attr:`commands` are the parsers of its commands, by name."""

    commands: dict[str, argparse.ArgumentParser]

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class Stop:
    """The signal that last stopped a command (SIGINT or SIGTERM)."""

    signal = signal.SIGINT


@contextmanager
def signals_interrupt() -> Iterator[None]:
    """While it lasts, SIGTERM stops a command as Ctrl-C does (KeyboardInterrupt), so outputs
    are finished or removed and worker processes ended; :func:`interrupted` gives the exit
    code. (Only in the main thread: elsewhere signals cannot be handled.)"""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, _: object) -> None:
        Stop.signal = signal.Signals(signum)
        raise KeyboardInterrupt

    Stop.signal = signal.SIGINT
    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, before in previous.items():
            signal.signal(s, signal.SIG_DFL if before is None else before)


def interrupted(signum: signal.Signals | None = None) -> int:
    """The exit code of a command stopped by ``signum`` (default: the last signal)."""
    return 128 + (signum or Stop.signal)


def stopped(signum: signal.Signals | None = None) -> str:
    """How a command was stopped, in words."""
    signum = signum or Stop.signal
    return "interrupted" if signum == signal.SIGINT else f"stopped by {signum.name}"


def check(files: Sequence[tuple[str, str | Path | None]] = (), *,
           folders: dict[str, str | Path | None] | None = None,
           inputs: Sequence[str | Path | None] = (), stdout: bool = True) -> bool:
    """:func:`k37.sim.files.check_outputs`, its error printed: whether the outputs can be
    written."""
    from k37.sim.files import OutputError, check_outputs

    try:
        check_outputs(files, folders=folders, inputs=inputs, stdout=stdout)
    except OutputError as e:
        print_error(e)
        return False
    return True


def stdout(write: Callable[[], object]) -> int:
    """Print to stdout with ``write``: 0, or :data:`EXIT_OUTPUT` with one error line if stdout
    fails (full, closed)."""
    from k37.sim.files import why

    try:
        write()
        sys.stdout.flush()
    except OSError as e:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        print(f"k37: error: stdout: not written: {why(e)}", file=sys.stderr)
        return EXIT_OUTPUT
    return 0


def print_error(e: Exception) -> None:
    """One ``k37: error:`` line per error (a program's errors come all at once)."""
    for line in str(e).splitlines() or [""]:
        print(f"k37: error: {line}", file=sys.stderr)


def positive_int(text: str) -> int:
    value = int(text.replace("_", ""))
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, not {text}")
    return value
