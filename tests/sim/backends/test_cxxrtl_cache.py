"""The compiled CXXRTL backend's model cache: a design's key finds its model without
elaborating it, and every source that makes a model (the build script, the generators, the
header, the harness) is in its key, so no model outlives an edit of what made it."""

import inspect
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from amaranth.hdl import Fragment

from k37.firmware_model.job import MachineConfig, demo_job
from k37.sim.backends import toolchain
from k37.sim.backends.cxxrtl import build
from k37.sim.backends.cxxrtl.backend import CxxrtlBackend, WaitEnd, _WaitPolling
from k37.sim.machine.system import System
from k37.sim.run import runner
from tests.paths import ROOT


def test_a_design_key_finds_the_model_without_elaborating_the_design(monkeypatch):
    job = demo_job()
    first = runner.build_backend(job, "cxxrtl")  # converts (or finds) and remembers
    system = System()
    converted = CxxrtlBackend._convert_and_build(system, None)[1]
    monkeypatch.setattr(Fragment, "get", lambda *_: pytest.fail("elaborated the design"))
    again = runner.build_backend(job, "cxxrtl")
    assert again.model.path == first.model.path and not again.model.built
    assert again._signed == set(converted["signed"]) and "x__error" in again._signed
    assert again.ports == first.ports and len(again.ports) == len(converted["ports"])
    assert again._free == system.free_running and again.design_name == "System"
    assert again.probe_names() == first.probe_names()
    first.close()
    again.close()


def test_a_run_of_a_remembered_design_never_imports_amaranth():
    """The run path of a cached design (the firmware, the register maps, the compiled model)
    is plain Python: a short job pays no HDL import."""
    runner.build_backend(demo_job(), "cxxrtl").close()  # remembered
    script = ("import sys\n"
              "from k37.firmware_model.job import demo_job\n"
              "from k37.sim.run.runner import RunOptions, build_backend, run_job\n"
              "job = demo_job()\n"
              "report = run_job(job, RunOptions(max_cycles=20000), build_backend(job, 'cxxrtl'))"
              ".report\n"
              "assert report['cycles'] == 20000, report['cycles']\n"
              "print(sorted(m for m in sys.modules if m.split('.')[0] == 'amaranth'))\n")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                            check=True, env=os.environ | {"PYTHONPATH": str(ROOT)})
    assert result.stdout.strip() == "[]", result.stdout + result.stderr


def test_the_design_key_follows_the_parameters_and_every_source(monkeypatch, make_job):
    pre, post = make_job("M30"), make_job("M30", MachineConfig(accel="post"))
    assert runner.design_key(pre) != runner.design_key(post)
    before = runner.design_key(pre)
    read = Path.read_bytes
    monkeypatch.setattr(Path, "read_bytes", lambda path: read(path) + (
        b"#" if path.name == "plant_model.py" else b""))
    runner._design_sources.cache_clear()
    try:
        assert runner.design_key(pre) != before
    finally:
        monkeypatch.undo()
        runner._design_sources.cache_clear()
    assert runner.design_key(pre) == before


#: The files of the harness (build.HARNESS): its translation unit and the parts it includes.
HARNESS = ("harness.cc", "model.h", "model.cc", "skip.h", "skip.cc", "plant.h", "lag.h", "plant.cc",
           "wait.h", "wait.cc")
#: The files that make a compiled model (build._makers).
MAKERS = ("build.py", "codegen.py", "evals.py", "rise.py", "words.h", *HARNESS)


def _edit_maker(monkeypatch: pytest.MonkeyPatch, maker: str) -> None:
    """Make the model's maker named ``maker`` (a file of sim/backends/cxxrtl) read as edited."""
    read, source = Path.read_text, inspect.getsource
    monkeypatch.setattr(Path, "read_text", lambda path, *args, **kwargs: read(
        path, *args, **kwargs) + ("//" if path.name == maker else ""))
    monkeypatch.setattr(inspect, "getsource", lambda obj: source(obj) + (
        "#" if Path(getattr(obj, "__file__", "")).name == maker else ""))


@pytest.mark.parametrize("maker", MAKERS)
def test_a_remembered_design_is_forgotten_when_what_makes_its_model_changes(monkeypatch, maker):
    """A model built by an older harness or generator must not stand for the design."""
    job = demo_job()
    runner.build_backend(job, "cxxrtl").close()  # remembered
    key = runner.design_key(job)
    assert build.find_design(key) is not None
    _edit_maker(monkeypatch, maker)
    assert build.find_design(key) is None


@pytest.mark.parametrize("maker", MAKERS)
def test_a_models_cache_key_changes_with_what_makes_it(monkeypatch, maker):
    """A model built by an older Yosys script, generator, header or harness is not reused."""
    before = build._model_key("rtlil", "runtime", ["free"], ["reads"])
    _edit_maker(monkeypatch, maker)
    assert build._model_key("rtlil", "runtime", ["free"], ["reads"]) != before


@pytest.mark.parametrize("source", HARNESS)
def test_the_harness_objects_cache_key_changes_with_each_of_its_files(monkeypatch, source):
    """The harness's object is not reused after an edit of any file it is compiled from."""
    before = build._runtime_key(build._harness(), "versions")
    _edit_maker(monkeypatch, source)
    assert build._runtime_key(build._harness(), "versions") != before


def test_every_cxx_file_of_the_backend_is_a_maker():
    """A C++ file that no key covers would let a model built before an edit of it stand."""
    package = Path(build.__file__).parent
    sources = {path.name for path in package.iterdir() if path.suffix in (".cc", ".h")}
    assert sources == {name for name in MAKERS if not name.endswith(".py")}
    assert build.HARNESS == HARNESS


def test_the_polling_waits_interface_is_the_same_on_both_sides():
    """backend.py mirrors wait.h: the fields of its arguments in order, and why it returns."""
    header = (Path(build.__file__).with_name("wait.h")).read_text()
    fields = re.search(r"struct WaitPolling \{(.*?)\};", header, re.DOTALL).group(1)
    names = re.findall(r"\b(\w+);", fields)
    assert names == [name for name, _ in _WaitPolling._fields_]
    body = re.search(r"enum class WaitEnd : int \{(.*?)\};", header, re.DOTALL).group(1)
    assert dict(re.findall(r"(\w+) = (\d+),", body)) == {e.name: str(e.value) for e in WaitEnd}


def test_a_second_build_of_an_entry_waits_for_the_first(tmp_path):
    """While one process builds a cache entry, another that would build the same entry waits
    for it (and then finds the model) instead of compiling it a second time."""
    script = ("import sys, time\n"
              "from pathlib import Path\n"
              "from k37.sim.backends.toolchain import key_lock\n"
              "root = Path(sys.argv[1])\n"
              "with key_lock(root, 'entry'):\n"
              "    (root / 'held').write_text('')\n"
              "    time.sleep(0.5)\n"
              "    (root / 'built').write_text('')\n")
    builder = subprocess.Popen([sys.executable, "-c", script, str(tmp_path)],
                               env=os.environ | {"PYTHONPATH": str(ROOT)})
    try:
        while not (tmp_path / "held").exists():
            assert builder.poll() is None, "the builder ended without taking the lock"
            time.sleep(0.01)
        with toolchain.key_lock(tmp_path, "entry"):
            assert (tmp_path / "built").exists()
        with toolchain.key_lock(tmp_path, "another entry"):  # other keys do not wait
            pass
    finally:
        assert builder.wait(timeout=60) == 0
