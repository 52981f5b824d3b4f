"""Waveforms: a third-party reader (pywellen, the library behind Surfer) opens the VCD, with
a scope per chip; the GTKWave save file shows every signal it lists, as GTKWave names it, in
the right number format, zoomed to the window; ``signals`` selects what is dumped."""

from __future__ import annotations

import math

import pytest
import pywellen

from k37.firmware_model.job import demo_job
from k37.sim.run.runner import OptionError, RunOptions, build_backend, run_job
from k37.sim.run.waveform import GTKW_GROUPS, GTKW_WIDTH_PX, wave_signals, wave_span, write_gtkw

CHIP_SCOPES = ("k3701", "k3702_x", "k3702_y", "encoder_x", "encoder_y", "feed", "decel",
               "accel")


def parse_gtkw(text: str) -> tuple[dict[str, str], list[tuple[int, str]]]:
    """A save file's ``[key] value`` settings (and ``*`` zoom line) and its traces as
    (flags, name), group markers included (``-name``)."""
    settings, traces, flags = {}, [], None
    for line in text.splitlines():
        if line.startswith("["):
            key, _, value = line[1:].partition("] ")
            settings[key] = value
        elif line.startswith("*"):
            settings["*"] = line[1:]
        elif line.startswith("@"):
            flags = int(line[1:], 16)
        else:
            assert flags is not None, f"a trace without flags: {line!r}"
            traces.append((flags, line))
    return settings, traces


@pytest.mark.parametrize("backend", ["pysim", "cxxrtl"])
def test_vcd_opens_in_pywellen_with_a_scope_per_chip_and_gtkw_shows_every_listed_signal(
        tmp_path, backend):
    vcd, gtkw = tmp_path / "run.vcd", tmp_path / "run.gtkw"
    run_job(demo_job(), RunOptions(backend=backend, max_cycles=1500, vcd=vcd, vcd_start=300))
    wave = pywellen.Waveform(str(vcd))
    scopes = {str(s).removeprefix("Scope(").removesuffix(")") for s in wave.all_scopes()}
    for chip in CHIP_SCOPES:
        assert f"bench.top.chipset.{chip}" in scopes, sorted(scopes)
    widths = wave_signals(vcd)
    assert set(widths) == {v.full_name for v in wave.all_vars()}
    window = (300 * 10**9, wave_span(vcd)[1])
    written = write_gtkw(vcd, gtkw, window=window)
    settings, traces = parse_gtkw(gtkw.read_text())
    signals = [(f, name) for f, name in traces if not name.startswith("-")]
    assert [name for _, name in signals] == written
    # Every listed signal the file declares is shown, multi-bit ones as GTKWave names them
    # (of alternatives, the chipset's step ports: the whole design is dumped).
    listed = [e.partition(":")[0].partition("|")[0] for _, names in GTKW_GROUPS for e in names
              if not e.startswith(("z__", "step_z"))]  # a two-axis machine
    traced = [n for n in listed if any(d.rsplit(".", 1)[-1] == n for d in widths)]
    assert len(traced) >= len(listed) - 1  # fp: a wire CXXRTL may inline
    assert len(signals) == len(traced)
    for (flags, name), short in zip(signals, traced, strict=True):
        base, _, bits = name.partition("[")
        assert base.rsplit(".", 1)[-1] == short
        width = widths[base]
        assert bits == ("" if width == 1 else f"{width - 1}:0]")
        signed = short.endswith(("__command", "__error", "__count"))
        expected = 0x28 if width == 1 else 0x22 if short.startswith("bus__") else \
            0x424 if signed else 0x24
        assert flags == expected, (name, hex(flags))
    # Grouped: each group's begin and end marker around its signals.
    groups = [name for _, name in traces if name.startswith("-")]
    assert groups[::2] == groups[1::2] == [f"-{g}" for g, _ in GTKW_GROUPS
                                           if not g.endswith(" z")]
    # Zoomed to the traced window: 2**-zoom fs per pixel.
    start, stop = window
    assert wave_span(vcd)[0] == (0 if backend == "pysim" else start - 250_000_000)
    assert int(settings["timestart"]) == start
    zoom = float(settings["*"].split()[0])
    assert math.isclose(2 ** -zoom * GTKW_WIDTH_PX, stop - start, rel_tol=1e-5)


def test_the_gtkw_signedness_matches_the_top_ports():
    ports = build_backend(demo_job(), "pysim").ports
    for _, names in GTKW_GROUPS:
        for entry in names:
            name, _, kind = entry.partition(":")
            if name in ports:
                assert ports[name].signed == (kind == "s"), name


def changes(path, names: set[str]) -> dict[str, list[tuple[int, object]]]:
    """The value changes of the signals ``names`` in a waveform file, by full name."""
    wave = pywellen.Waveform(str(path))
    out: dict[str, list[tuple[int, object]]] = {}
    for var in wave.all_vars():
        if var.full_name in names:
            found = out[var.full_name] = []
            wave.stream_changes(lambda t, _, v, found=found: found.append((t, v)), [var])
    return out


@pytest.mark.parametrize("backend", ["pysim", "cxxrtl"])
def test_signals_selects_what_is_dumped_with_the_same_values(tmp_path, backend):
    full, part = tmp_path / "full.vcd", tmp_path / "part.vcd"
    globs = ("chipset.k3701.*", "x__*")
    for path, signals in ((full, ()), (part, globs)):
        run_job(demo_job(), RunOptions(backend=backend, max_cycles=1200, vcd=path,
                                       vcd_start=200, signals=signals))
    everything, selected = wave_signals(full), wave_signals(part)
    top = "bench.top."
    expected = {n for n in everything if n.startswith((top + "chipset.k3701.", top + "x__"))}
    # The K3701 (three datapaths) is about a quarter of the design's signals; x__* a few.
    assert set(selected) == expected and len(expected) < len(everything) / 3
    dumped = changes(full, expected)
    assert sum(map(len, dumped.values())) > 2 * len(expected)  # values that change
    assert changes(part, expected) == dumped
    with pytest.raises(OptionError, match=r"--signals nothing\.\*: matches no signal"):
        run_job(demo_job(), RunOptions(backend=backend, max_cycles=10, vcd=part,
                                       signals=("nothing.*",)))


@pytest.mark.parametrize("backend", ["pysim", "cxxrtl"])
def test_fst_holds_the_same_signals_and_changes_as_the_vcd(tmp_path, backend):
    vcd, fst = tmp_path / "run.vcd", tmp_path / "run.fst"
    for path in (vcd, fst):
        run_job(demo_job(), RunOptions(backend=backend, max_cycles=3000, vcd=path,
                                       vcd_start=500))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.fst", "run.vcd"]  # no partial
    assert pywellen.Waveform(str(fst)).file_format == "FST"
    declared = wave_signals(vcd)
    # FSM states (Amaranth's simulator writes them as text) are FST's width-less strings
    text = {v.full_name for v in pywellen.Waveform(str(vcd)).all_vars() if v.is_string}
    assert wave_signals(fst) == {n: 0 if n in text else w for n, w in declared.items()}
    assert wave_span(fst) == wave_span(vcd)
    dumped = changes(vcd, set(declared))
    assert sum(map(len, dumped.values())) > 3 * len(declared)
    assert changes(fst, set(declared)) == dumped
    assert fst.stat().st_size * 4 < vcd.stat().st_size
    shown = write_gtkw(fst, tmp_path / "fst.gtkw")
    assert shown == write_gtkw(vcd, tmp_path / "vcd.gtkw")
    assert '[dumpfile] "run.fst"' in (tmp_path / "fst.gtkw").read_text()


def test_the_gtkw_names_its_waveform_from_its_own_folder(tmp_path):
    """GTKWave resolves the dump file against the save file's own place (the folder of its
    ``[savefile]``): the pair moved together still opens."""
    waves = tmp_path / "waves"
    waves.mkdir()
    vcd = waves / "run.vcd"
    run_job(demo_job(), RunOptions(backend="cxxrtl", max_cycles=2000, vcd=vcd))
    gtkw = tmp_path / "view.gtkw"
    write_gtkw(vcd, gtkw)
    settings, _ = parse_gtkw(gtkw.read_text())
    assert settings["dumpfile"] == '"waves/run.vcd"' and settings["savefile"] == '"view.gtkw"'
    moved = tmp_path / "elsewhere"
    (moved / "waves").mkdir(parents=True)
    vcd.rename(moved / "waves" / "run.vcd")
    gtkw.rename(moved / "view.gtkw")
    assert (moved / settings["dumpfile"].strip('"')).exists()


def test_the_gtkw_shows_the_k3701s_step_pulses_when_only_the_k3701_is_dumped(tmp_path):
    vcd = tmp_path / "run.vcd"
    run_job(demo_job(), RunOptions(backend="cxxrtl", max_cycles=20_000, vcd=vcd,
                                   signals=("chipset.k3701.*", "x__*")))
    write_gtkw(vcd, tmp_path / "run.gtkw")
    _, traces = parse_gtkw((tmp_path / "run.gtkw").read_text())
    names = [name for _, name in traces]
    group = names[names.index("-K3701") + 1:names.index("-K3701", names.index("-K3701") + 1)]
    assert [n.rsplit(".", 1)[-1] for n in group] == ["x_pos", "x_neg", "y_pos", "y_neg"]
    assert all(".k3701." in n for n in group)
