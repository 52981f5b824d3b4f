"""Building the engine: its C++ (``machine.cc`` and the headers it includes) and the constants
header generated from the register maps (:mod:`.constants`), compiled with g++ into a shared
library and cached like the compiled RTL models (:mod:`k37.sim.backends.toolchain`), under
``~/.cache/k37/engine/<sha256>/``, keyed by the sources, the generated header, the flags and
the compiler's version."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

from k37.sim.backends.engine.constants import header
from k37.sim.backends.toolchain import (
    Model,
    build_dir,
    cache_root,
    find_compiler,
    finish,
    key_lock,
    progress,
    sha256,
)

__all__ = ["SOURCES", "build"]

#: The engine's sources: its one translation unit (first) and the headers it includes, and
#: the plant's update that it shares with the compiled RTL harness (a path from here).
SOURCES = ("machine.cc", "machine.h", "blocks.h", "plant.h", "curves.h", "drives.h", "k3701.h",
           "free.h", "axes.h", "../cxxrtl/lag.h")
#: g++ flags of the engine library (part of the cache key).
CXX_FLAGS = ("-std=c++17", "-O3", "-fPIC", "-shared", "-fvisibility=hidden")
_LIBRARY = "libk37engine.so"


def build(compiler: str | None = None) -> Model:
    """The engine's library, built now or found in the cache."""
    compiler = compiler or find_compiler()
    if compiler is None:
        raise RuntimeError("the engine needs a C++ compiler: g++ is not on PATH "
                           "(set CXX to use another)")
    here = Path(__file__).parent
    constants = header()
    version = subprocess.run([compiler, "--version"], capture_output=True, text=True,
                             check=True).stdout
    key = sha256(constants, version, " ".join(CXX_FLAGS),
                 *((here / name).read_text() for name in SOURCES))
    root = cache_root("engine")
    library = root / key / _LIBRARY
    if library.exists():
        return Model(library, False, {})
    with key_lock(root, key):
        if library.exists():
            return Model(library, False, {})
        start = time.perf_counter()
        progress("engine", "compiling the engine (about 10 s)")
        with build_dir(root, key) as work:
            for name in SOURCES:
                (work / Path(name).name).write_text((here / name).read_text())
            (work / "constants.h").write_text(constants)
            finish(subprocess.Popen([compiler, *CXX_FLAGS, SOURCES[0], "-o", _LIBRARY],
                                    cwd=work, stderr=subprocess.PIPE, text=True), "the engine")
        return Model(library, True, {"compile": time.perf_counter() - start})
