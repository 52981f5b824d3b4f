"""FPGA synthesis: every exported block fits an iCE40 HX8K and runs at 10x the system clock.

One run of the full flow (Yosys and nextpnr for every registered block) serves the tests that
read the report; one small run on the UP5K checks that failures are reported.
"""

from __future__ import annotations

import pytest

from k37.sim.fpga.blocks import BLOCKS
from k37.sim.fpga.synth import DEVICES, TARGET_MHZ, synthesize

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def hx8k(tmp_path_factory):
    return synthesize("ice40-hx8k", work_dir=tmp_path_factory.mktemp("synth"))


def test_every_block_fits_the_hx8k_and_reaches_10x_the_system_clock(hx8k):
    assert hx8k.ok, hx8k.format_table()
    assert TARGET_MHZ == 10.0
    for result in [*hx8k.blocks, hx8k.total]:
        assert result.fits, result.error
        assert result.fmax_mhz >= TARGET_MHZ, result.name


def test_the_total_fits_the_device(hx8k):
    assert 0 < hx8k.total.logic_cells <= DEVICES["ice40-hx8k"].logic_cells
    assert hx8k.total.io_pins <= DEVICES["ice40-hx8k"].io_pins or not hx8k.total_is_sum


def test_the_report_has_every_block_and_counts_its_resources(hx8k):
    total = next(b.name for b in BLOCKS if b.top)  # the first top
    assert [r.name for r in hx8k.blocks] == [b.name for b in BLOCKS
                                             if b.ice40 and b.name != total]
    for r in hx8k.blocks:
        assert r.luts > 0 and r.ffs > 0 and r.io_pins > 0, r
        assert r.logic_cells >= max(r.ffs, r.luts - r.carries), r
    if hx8k.total_is_sum:
        assert hx8k.total.luts == sum(r.luts for r in hx8k.blocks)
        assert hx8k.total.fmax_mhz == min(r.fmax_mhz for r in hx8k.blocks)


def test_the_table_lists_luts_flip_flops_and_fmax_per_block_and_in_total(hx8k):
    table = hx8k.format_table()
    assert table.startswith("Device ice40-hx8k (7680 logic cells, 206 I/O); target 10 MHz; "
                            "Yosys ")
    assert "| block | LUT4 | flip-flops | carries | logic cells | I/O | fmax (MHz) |" in table
    k3701 = next(r for r in hx8k.blocks if r.name == "k3701")
    assert (f"| k3701 | {k3701.luts} | {k3701.ffs} | {k3701.carries} | {k3701.logic_cells} | "
            f"{k3701.io_pins} | {k3701.fmax_mhz:.1f} |") in table
    total = hx8k.total
    assert (f"| **total{' (sum of the blocks)' if hx8k.total_is_sum else ': chipset'}** | "
            f"{total.luts} | {total.ffs} |") in table


def test_too_many_pins_and_too_slow_a_clock_are_reported_as_failures(tmp_path):
    report = synthesize("ice40-up5k", ["divider", "k3702"], work_dir=tmp_path,
                        target_mhz=1000.0)
    assert not report.ok
    divider, k3702 = report.blocks
    assert divider.fits and divider.fmax_mhz < 1000.0
    assert not k3702.fits and k3702.fmax_mhz is None
    assert report.failures == [
        f"divider: fmax {divider.fmax_mhz:.1f} MHz < 1000 MHz",
        f"k3702: k3702 needs {k3702.io_pins} I/O pins; ice40-up5k has 39",
    ]
    assert "- FAIL: k3702: k3702 needs" in report.format_table()


def test_an_unknown_device_or_block_is_refused():
    with pytest.raises(ValueError, match=r"device must be one of ice40-hx8k, ice40-up5k, not "
                                         r"'ecp5'"):
        synthesize("ecp5")
    with pytest.raises(ValueError, match="unknown block 'k9999'"):
        synthesize(blocks=["k9999"])
