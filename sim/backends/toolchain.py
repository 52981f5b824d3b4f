"""What the compiled models share: the C++ compiler, the model cache and its build folders.

Models are cached under ``~/.cache/k37/<kind>/<sha256>/`` (or ``$K37_CACHE_DIR/<kind>``), keyed
by everything that shapes them; nothing is ever evicted. A build happens in a private folder
that is renamed into place, so parallel builds never see a half-written entry, and under a
lock on its key (:func:`key_lock`), so a second build of the same entry waits for the first
and uses its model instead of compiling it again.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

try:
    import fcntl
except ImportError:  # not POSIX: builds of one entry may run side by side
    fcntl = None

__all__ = ["Model", "build_dir", "cache_root", "find_compiler", "finish", "key_lock",
           "progress", "sha256"]


@dataclass(frozen=True)
class Model:
    """A built model library: its path, whether this call built it, and the build phases' times."""

    path: Path
    built: bool
    seconds: dict[str, float]


def find_compiler() -> str | None:
    """The C++ compiler to use (``$CXX`` or ``g++``), or None if it is not on PATH."""
    return shutil.which(os.environ.get("CXX", "g++"))


def cache_root(kind: str) -> Path:
    """Where built models of ``kind`` (``cxxrtl``, ``verilator``) are kept."""
    env = os.environ.get("K37_CACHE_DIR")
    return (Path(env) if env else Path.home() / ".cache" / "k37") / kind


def progress(kind: str, message: str) -> None:
    """One line about a build on stderr."""
    print(f"k37 {kind}: {message}", file=sys.stderr, flush=True)


def sha256(*parts: str) -> str:
    """The cache key of ``parts``."""
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()


def finish(job: subprocess.Popen, what: str) -> None:
    """Wait for a compile started with ``stderr=PIPE``; raise with its output if it failed."""
    _, stderr = job.communicate()
    if job.returncode:
        raise RuntimeError(f"compiling {what} failed:\n{stderr[-4000:]}")


@contextmanager
def build_dir(root: Path, key: str) -> Iterator[Path]:
    """A private folder in which to build the cache entry ``root/key``.

    On success the folder is renamed into place, so parallel builds never see a half-written
    entry (if another build got there first, its entry stays).
    """
    root.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=root, prefix=".build-") as tmp:
        work = Path(tmp) / key
        work.mkdir()
        yield work
        try:
            work.rename(root / key)
        except OSError:
            if not (root / key).exists():
                raise


@contextmanager
def key_lock(root: Path, key: str) -> Iterator[None]:
    """Held while the cache entry ``root/key`` is built: another process building the same
    entry (a study's other worker, another test worker) waits here, then finds the entry
    built. The lock is the operating system's (``flock``): a build that dies releases it."""
    root.mkdir(parents=True, exist_ok=True)
    if fcntl is None:
        yield
        return
    with open(root / f".{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
