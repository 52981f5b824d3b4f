"""Verilog export: one file per chip with the chips' pin names, a header, and a clean lint."""

from __future__ import annotations

import functools
import re
import shutil
from pathlib import Path

import pytest
from amaranth.back import verilog

from k37.hdl.feed.divider import PhaseDivider
from k37.sim.backends.verilator.model import lint
from k37.sim.fpga.blocks import BLOCKS, Exportable, block
from k37.sim.fpga.export import CORE_WAIVERS, export_verilog, pins, verilog_text

NAMES = [b.name for b in BLOCKS]


@functools.cache
def text(name: str) -> str:
    return verilog_text(name)


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("verilog") / "nested"
    return {path.stem: path for path in export_verilog(None, out)}


def port_list(source: str, module: str) -> list[str]:
    """The port names of ``module``'s ANSI header, in order."""
    header = re.search(rf"^module {module} \((.*?)^\);", source, re.M | re.S)
    assert header is not None, f"no module {module}"
    return re.findall(r"^\s+(?:input|output|inout)\s+wire\s+(?:\[\d+:0\])?\s*(\w+)",
                      header.group(1), re.M)


def test_export_all_writes_one_file_per_registered_block(exported):
    assert list(exported) == NAMES
    for name, path in exported.items():
        assert path.read_text() == text(name)
        assert re.search(rf"^module {name} \(", path.read_text(), re.M)


def test_named_blocks_are_written_in_the_order_given(tmp_path, monkeypatch):
    monkeypatch.setattr("k37.sim.fpga.export.verilog_text", text)  # the files' text is tested above
    paths = export_verilog(["divider", "rate_multiplier"], tmp_path)
    assert paths == [tmp_path / "divider.v", tmp_path / "rate_multiplier.v"]
    assert export_verilog(["all"], tmp_path) == [tmp_path / f"{n}.v" for n in NAMES]


def test_an_unknown_block_is_refused_before_anything_is_written(tmp_path):
    with pytest.raises(ValueError, match=r"unknown block 'k9999'; blocks are k3701, k3702, "):
        export_verilog(["divider", "k9999"], tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_the_header_names_the_parameters_and_the_register_map_version():
    k3701 = text("k3701")
    assert ("// Parameters: latency_linear = 11, latency_circular = 21, circle_setup = 25, "
            "axes = 2.") in k3701
    assert "// Register map K3701, version 1 (25 bytes;" in k3701
    assert "//   0x0e  STATUS          8 bits  r" in k3701
    assert "// Parameters: n = 15, counter_width = 24, bidirectional = True." in \
        text("accel_decel_axis")
    assert "// Parameters: none." in text("k3702")
    assert "Register map" not in text("divider")


def test_the_bus_becomes_the_chips_pins_with_active_low_strobes():
    by_name = {p.name: p for p in pins("k3701")}
    assert [n for n in by_name if n in ("d", "addr", "cs_n", "rd_n", "wr_n")] == \
        ["d", "addr", "cs_n", "rd_n", "wr_n"]
    assert (by_name["d"].direction, by_name["d"].width) == ("inout", 8)
    assert (by_name["addr"].direction, by_name["addr"].width) == ("input", 5)
    assert {by_name[n].label for n in ("cs_n", "rd_n", "wr_n")} == {"/CS", "/RD", "/WR"}
    assert (by_name["clk"].label, by_name["irq"].label, by_name["x_neg"].label) == \
        ("CP", "INT", "-X")
    source = text("k3701")
    assert ".bus__w_stb(~cs_n & ~wr_n)" in source
    assert ".bus__r_stb(~cs_n & ~rd_n)" in source


def test_every_wrapper_has_exactly_its_pins_in_its_port_list():
    for name in NAMES:
        assert port_list(text(name), name) == [p.name for p in pins(name)]
        assert not any("__" in p.name for p in pins(name))


def test_pins_keep_the_spec_names_and_alarm_stays_active_low():
    k3702 = {p.name: p for p in pins("k3702")}
    assert k3702["alarm_n"].label == "ALARM"
    assert {"com_pos", "com_neg", "fb_pos", "fb_neg", "dac"} <= set(k3702)
    encoder = [p.name for p in pins("encoder")]
    assert {"a", "a_n", "b", "b_n", "fb_pos", "fb_neg"} <= set(encoder)


def test_probe_ports_stay_inside_the_core():
    assert not {"command", "error"} & {p.name for p in pins("k3702")}
    assert ".command()," in text("k3702")
    assert "// Probe outputs of the core, not chip pins, left unconnected here: command, " \
           "error." in text("k3702")


def test_the_chipset_top_has_only_the_boards_pins():
    names = {p.name for p in pins("chipset")}
    axis = {"dac", "alarm_n", "a", "a_n", "b", "b_n"}
    bus = {"d", "addr", "cs_n", "rd_n", "wr_n"}
    assert names == {"clk", "rst", "irq_interp", "irq_alarm", *bus,
                     *(f"{x}_{n}" for x in ("x", "y") for n in axis)}


def test_simulation_observation_is_never_a_pin():
    for name in NAMES:
        assert "quiet" not in {p.name for p in pins(name)}
        assert "quiet" not in port_list(text(name), name)


def test_pin_comments_come_from_the_members_docstring():
    assert re.search(r"input  wire +fp, +// FP: Feed pulse, sampled every cycle", text("k3701"))


def _initialisers_back(source: str) -> str:
    """``source`` with each ``reg`` declaration and the ``initial`` statement after it merged
    back into a declaration with an initialiser, as Amaranth writes it."""
    def merged(m: re.Match) -> str:
        indent, width, name, value = m.group(1, 2, 3, 5)
        return f"{indent}reg {width}{name}{' ' if name.startswith(chr(92)) else ''} = {value};"
    return re.sub(r"^( *)reg ((?:\[[^\]]*\] )?)(\S+)( ?);\n\1initial \3 = ([^;]+);$",
                  merged, source, flags=re.M)


@pytest.mark.parametrize("name", ["decel_control", "k3702"])
def test_the_core_is_amaranths_verilog_with_power_up_values_in_initial_statements(name):
    entry = block(name)
    core = verilog.convert(entry.component(), name=f"{name}_core", emit_src=False)
    source = text(name)
    assert not re.search(r"^ *reg [^;]*=", source, re.M)  # no initialiser left
    assert core.replace("(* top =  1  *)\n", "", 1) in _initialisers_back(source)


class BadProbes(PhaseDivider):
    """A divider that declares an observation output it does not have."""

    @property
    def probes(self) -> tuple[str, ...]:
        return ("stb", "nope")


def test_a_probe_that_is_not_an_output_port_is_refused(monkeypatch):
    bad = Exportable("bad", f"{__name__}:BadProbes", "test")
    monkeypatch.setattr("k37.sim.fpga.blocks.BLOCKS", (*BLOCKS, bad))
    with pytest.raises(ValueError, match=r"bad: probes \['nope'\] are not output ports"):
        pins("bad")


@pytest.mark.parametrize("name", NAMES)
def test_every_exported_file_is_lint_clean_under_verilator_wall(exported, name):
    result = lint(exported[name], top=name)
    assert result.clean, result.output[-3000:]


_SYSTEM_VERILATOR = shutil.which("verilator")


@pytest.mark.skipif(_SYSTEM_VERILATOR is None, reason="no verilator on PATH (Debian's: apt "
                                                      "install verilator)")
def test_every_exported_file_is_lint_clean_under_the_verilator_on_path(exported):
    """An older Verilator (Debian 12's 5.006) knows every waived rule and finds nothing."""
    for name in NAMES:
        result = lint(exported[name], top=name, verilator=_SYSTEM_VERILATOR)
        assert result.clean, result.output[-3000:]


def test_the_lint_catches_a_width_mismatch_in_the_wrapper(tmp_path):
    source = text("divider").replace("module divider (", "module divider (\n"
                                     "    input  wire [1:0]  spare,", 1)
    source = source.replace(".rst(rst),", ".rst(spare),", 1)
    path = tmp_path / "divider.v"
    path.write_text(source)
    assert not lint(path, top="divider").clean


def test_every_lint_waiver_gives_its_reason_and_is_closed():
    for name in NAMES:
        source = text(name)
        offs = re.findall(r"/\* verilator lint_off (\w+) \*/(.*)", source)
        assert offs, name
        for rule, reason in offs:
            assert len(reason.removeprefix("  // ").split()) >= 6, f"{name}: {rule} has no reason"
            assert f"/* verilator lint_on {rule} */" in source
        assert {rule for rule, _ in offs} >= set(CORE_WAIVERS)


def test_the_soc_and_board_blocks_have_their_buses_and_the_boards_pins():
    wishbone = {p.name: p.direction for p in pins("chipset_wishbone")}
    assert {k: wishbone[k] for k in ("wb_adr", "wb_dat_r", "wb_ack", "wb_cyc")} == \
        {"wb_adr": "input", "wb_dat_r": "output", "wb_ack": "output", "wb_cyc": "input"}
    assert "d" not in wishbone and "Wishbone bus (wb_*): a classic (B4) target" in \
        text("chipset_wishbone")
    bridge = {p.name: p.direction for p in pins("bridge")}
    assert {k: bridge[k] for k in ("rx", "tx", "bus_addr", "bus_w_stb", "bus_r_data")} == \
        {"rx": "input", "tx": "output", "bus_addr": "output", "bus_w_stb": "output",
         "bus_r_data": "input"}
    board = {p.name: p for p in pins("board_ulx3s")}
    assert (board["x_dac"].label, board["uart_rx"].direction) == ("GP4", "input")
    assert "reset" not in board and "the board's 25 MHz clock" in text("board_ulx3s")
