"""Files a command writes: proven writable before any work starts, written whole or not at all.

:func:`check_outputs` is what every ``k37`` command calls before it runs anything: each output
file's folder must exist and take a new file (a probe file is created beside the target and
removed), an existing target must be a file (or a device or pipe that can be written), each
output folder must be a folder that can be made and written, stdout must be open for writing
when the command prints to it, and no output may be an input of the same command or another
output. :func:`atomic_path` and :func:`atomic_open` write an output to a temporary file beside
its target and rename it over the target only when it is complete, so a full disk or an I/O
error leaves the previous file (or none), never a torn one.

Read limits are here too: :func:`read_program_text` reads a job or program file that must be a
regular file (or stdin) of at most :data:`MAX_INPUT_BYTES`.
"""

from __future__ import annotations

import contextlib
import fcntl
import glob
import io
import os
import stat
import sys
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

__all__ = ["MAX_INPUT_BYTES", "STDIO", "InputError", "OutputError", "OutputFailure",
           "atomic_open", "atomic_path", "check_outputs", "discard_temporary", "keep_temporary",
           "read_input_text", "temporary_beside", "why"]

#: Standard input or output, where a path is expected.
STDIO = "-"

#: The largest job, program or study file read (bytes): far above any CAM program
#: (a 100,000-block program is about 3 MB), far below what exhausts memory.
MAX_INPUT_BYTES = 64 << 20


class OutputError(ValueError):
    """An output that cannot be written; one line, naming the option (if any) and the path."""


class InputError(ValueError):
    """An input file that cannot be read; one line naming the path."""


@dataclass(frozen=True)
class OutputFailure:
    """An output that could not be written after the work was done (nothing left there)."""

    label: str
    path: str
    reason: str

    def __str__(self) -> str:
        return f"{_named(self.label, self.path)}: not written: {self.reason}"


def why(e: BaseException) -> str:
    """An OS error's reason in words, without the path (the caller names it)."""
    if isinstance(e, OSError) and e.strerror:
        return e.strerror
    return str(e) or type(e).__name__


def _named(label: str, path: str | Path) -> str:
    return f"{label} {path}" if label else str(path)


def _stdout_problem() -> str | None:
    """Why stdout cannot be written, or None."""
    stream = sys.stdout
    if stream is None:
        return "closed"
    try:
        fd = stream.fileno()
    except (OSError, ValueError, io.UnsupportedOperation):
        return None  # a stream without a descriptor (a test's capture): writable
    try:
        mode = fcntl.fcntl(fd, fcntl.F_GETFL) & os.O_ACCMODE
    except OSError:
        return "closed"
    if mode == os.O_RDONLY:
        return "open for reading only"
    return None


def _identity(path: Path) -> tuple[Any, ...]:
    """What two names of one file share: the device and inode if it exists, else its path."""
    try:
        st = path.stat()
        return ("inode", st.st_dev, st.st_ino)
    except OSError:
        return ("path", os.path.realpath(path))


def _probe_folder(folder: Path) -> str | None:
    """Why a new file cannot be made in ``folder`` (a probe created and removed), or None."""
    try:
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".k37-probe-")
    except OSError as e:
        return f"cannot write in {folder}: {why(e)}"
    os.close(fd)
    os.unlink(probe)
    return None


def _file_problem(path: Path) -> str | None:
    """Why an output file cannot be written at ``path``, or None."""
    try:
        st = path.stat()
    except FileNotFoundError:
        st = None
    except OSError as e:
        return why(e)
    if st is not None and stat.S_ISDIR(st.st_mode):
        return "is a folder, not a file"
    if st is not None and not stat.S_ISREG(st.st_mode):
        # a device or a pipe (/dev/null, >(...)): written in place
        try:
            fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
        except OSError as e:
            return f"cannot write: {why(e)}"
        try:
            if stat.S_ISCHR(st.st_mode):
                os.write(fd, b"")
        except OSError as e:
            return f"cannot write: {why(e)}"
        finally:
            os.close(fd)
        return None
    folder = path.parent
    if not folder.is_dir():
        return f"the folder {folder} does not exist"
    return _probe_folder(folder)


def _folder_problem(path: Path) -> str | None:
    """Why ``path`` cannot be (made and) used as an output folder, or None."""
    if path.exists() and not path.is_dir():
        return "is a file, not a folder"
    existing = path
    while not existing.exists():  # the nearest folder that exists: where mkdir writes
        if existing.parent == existing:
            break
        existing = existing.parent
    if not existing.is_dir():
        return f"{existing} is a file, not a folder"
    return _probe_folder(existing)


def check_outputs(files: Mapping[str, str | Path | None] | Iterable[tuple[str, str | Path | None]],
                  *, folders: Mapping[str, str | Path | None] | None = None,
                  inputs: Iterable[str | Path | None] = (), stdout: bool = False) -> None:
    """Refuse, before any work, outputs that could not be written.

    ``files`` and ``folders`` map an option (``"--json"``, or ``""`` for none) to its path
    (None: not asked for; :data:`STDIO` in ``files``: standard output). ``inputs`` are the
    files the command reads; ``stdout``: the command prints to standard output.

    Raises
    ------
    OutputError
        One line: the option, the path and why.
    """
    items = list(files.items() if isinstance(files, Mapping) else files)
    seen: dict[tuple[Any, ...], str] = {}
    for path in inputs:
        if path is not None and str(path) != STDIO:
            seen.setdefault(_identity(Path(path)), f"the input {path}")
    if stdout or any(str(p) == STDIO for _, p in items if p is not None):
        problem = _stdout_problem()
        if problem is not None:
            label = next((f"{lbl} " for lbl, p in items if str(p) == STDIO and lbl), "")
            raise OutputError(f"{label}stdout: {problem}")
    for label, path in items:
        if path is None or str(path) == STDIO:
            continue
        path = Path(path)
        other = seen.get(_identity(path))
        if other is not None:
            verb = "would overwrite" if other.startswith("the input") else "is the same file as"
            raise OutputError(f"{_named(label, path)}: {verb} {other}")
        problem = _file_problem(path)
        if problem is not None:
            raise OutputError(f"{_named(label, path)}: {problem}")
        seen[_identity(path)] = _named(label, path)
    for label, path in (folders or {}).items():
        if path is None:
            continue
        problem = _folder_problem(Path(path))
        if problem is not None:
            raise OutputError(f"{_named(label, path)}: {problem}")


def _in_place(path: Path) -> bool:
    """Whether ``path`` is written where it is (a device or pipe), not by a rename."""
    try:
        return not stat.S_ISREG(path.stat().st_mode)
    except FileNotFoundError:
        return False


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def temporary_beside(path: Path, suffix: str | None = None) -> Path:
    """A new empty file beside ``path`` to write its output into (``suffix``, default
    ``path``'s, for writers that go by it), with the permissions a new file gets; or ``path``
    itself if it is a device or a pipe, written in place."""
    if _in_place(path):
        return path
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.",
                                suffix=f".partial{path.suffix if suffix is None else suffix}")
    os.close(fd)
    os.chmod(name, 0o666 & ~_umask())
    return Path(name)


def keep_temporary(tmp: Path, path: Path) -> None:
    """Rename a complete ``tmp`` (:func:`temporary_beside`) over ``path``."""
    if tmp != path:
        os.replace(tmp, path)


def discard_temporary(tmp: Path) -> None:
    """Remove ``tmp`` (:func:`temporary_beside`) and any file a writer made beside it with its
    name as a prefix; a device or pipe written in place is left alone."""
    if _in_place(tmp):
        return
    for leftover in [tmp, *tmp.parent.glob(glob.escape(tmp.name) + "?*")]:
        with contextlib.suppress(OSError):
            leftover.unlink()


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` (with its suffix, for writers that go by it) to write
    the output to; renamed over ``path`` when the block ends, removed (with any file a writer
    made beside it) if it raises. A device or pipe is written in place."""
    path = Path(path)
    tmp = temporary_beside(path)
    try:
        yield tmp
        keep_temporary(tmp, path)
    except BaseException:
        discard_temporary(tmp)
        raise


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w", **kwargs: Any) -> Iterator[IO[Any]]:
    """``open`` a temporary file beside ``path``; renamed over it once written and closed."""
    with atomic_path(path) as tmp, open(tmp, mode, **kwargs) as f:
        yield f
        f.flush()


def read_input_text(path: str | Path, *, encoding: str = "utf-8",
                    limit: int = MAX_INPUT_BYTES) -> str:
    """The text of an input file: a regular file (or ``-``, stdin) of at most ``limit`` bytes.

    Raises
    ------
    InputError
        Not a regular file, too large, unreadable or not text in ``encoding``; naming why
        (the caller names the path).
    OSError, ValueError
        As ``open`` raises them (the caller words them).
    """
    if str(path) == STDIO:
        data = sys.stdin.buffer.read(limit + 1)
    else:
        with open(path, "rb") as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode):
                raise InputError("not a regular file (a job or program is read from a file "
                                 "or from stdin, '-')")
            if st.st_size > limit:
                raise InputError(f"{st.st_size:,} bytes, more than the {limit:,} bytes a job "
                                 f"or program may have")
            data = f.read(limit + 1)
    if len(data) > limit:
        raise InputError(f"more than the {limit:,} bytes a job or program may have")
    return data.decode(encoding)
