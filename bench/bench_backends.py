"""Cycles per second of Amaranth's simulator and of the compiled CXXRTL backend.

Run with ``pytest bench/bench_backends.py``. The design is a small interpolating chip: an
8-bit host bus with 24-bit registers, a feed-rate phase accumulator, a two-axis DDA with 24-bit
accumulators and position counters, and an interrupt at the end of each move. The firmware loop
is the one the emulator runs: load a move over the bus, wait for the interrupt, read the
positions back. Both backends run the same moves; the summary prints both speeds and the ratio.
"""

import time

import pytest
from amaranth.hdl import Module, Mux, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from k37.hdl.bus.hostbus import HostBus, RegisterBank
from k37.hdl.bus.registers import Access, Register, RegisterMap
from k37.sim.backends.contract import Backend
from k37.sim.backends.cxxrtl.backend import CxxrtlBackend
from k37.sim.backends.pysim import PysimBackend

MAP = RegisterMap("BENCH", 1, (
    Register("DX", 0x00, 24, Access.W, "X distance of the next move", signed=True),
    Register("DY", 0x03, 24, Access.W, "Y distance of the next move", signed=True),
    Register("FEED", 0x06, 16, Access.W, "feed rate: steps per cycle times 2**16"),
    Register("START", 0x08, 8, Access.W, "any write starts the move"),
    Register("X", 0x09, 24, Access.R, "X position", signed=True),
    Register("Y", 0x0C, 24, Access.R, "Y position", signed=True),
    Register("STATUS", 0x0F, 8, Access.R, "bit 0: busy; reading clears the interrupt"),
))


class BenchChip(wiring.Component):
    """A two-axis DDA interpolator behind :data:`MAP`.

    Members
    -------
    bus : In(HostBus)
        The host bus.
    irq : Out(1)
        High from the end of a move until STATUS is read.
    """

    bus: In(HostBus(MAP.addr_width))
    irq: Out(1)

    def elaborate(self, platform):
        m = Module()
        m.submodules.regs = regs = RegisterBank(MAP)
        connect(m, flipped(self.bus), regs.bus)

        phase, feed_pulse = Signal(16), Signal()
        m.d.sync += [phase.eq(phase + regs.feed.w_data),
                     feed_pulse.eq((phase + regs.feed.w_data)[16])]

        busy, remaining, length = Signal(), Signal(24), Signal(24)
        m.d.comb += [regs.status.r_data.eq(busy), regs.x.r_data.eq(0), regs.y.r_data.eq(0)]
        with m.If(regs.status.r_stb):
            m.d.sync += self.irq.eq(0)
        steps = []
        for axis, distance, position in (("x", regs.dx, regs.x), ("y", regs.dy, regs.y)):
            magnitude = Signal(24, name=f"{axis}_magnitude")
            acc = Signal(25, name=f"{axis}_acc")
            pos = Signal(signed(24), name=f"{axis}_pos")
            step = Signal(name=f"{axis}_step")
            m.d.comb += [magnitude.eq(Mux(distance.w_data[23], -distance.w_data,
                                          distance.w_data)),
                         step.eq(busy & feed_pulse & (acc + magnitude >= length)),
                         position.r_data.eq(pos)]
            with m.If(regs.start.w_stb):
                m.d.sync += acc.eq(0)
            with m.Elif(busy & feed_pulse):
                m.d.sync += acc.eq(Mux(step, acc + magnitude - length, acc + magnitude))
            with m.If(step):
                m.d.sync += pos.eq(Mux(distance.w_data[23], pos - 1, pos + 1))
            steps.append(magnitude)

        with m.If(regs.start.w_stb):
            longest = Mux(steps[0] > steps[1], steps[0], steps[1])
            m.d.sync += [busy.eq(longest != 0), remaining.eq(longest), length.eq(longest)]
        with m.Elif(busy & feed_pulse):
            m.d.sync += remaining.eq(remaining - 1)
            with m.If(remaining == 1):
                m.d.sync += [busy.eq(0), self.irq.eq(1)]
        return m


def write_reg(backend: Backend, reg: Register, value: int) -> None:
    for k, byte in enumerate(reg.to_bytes(value)):
        backend.bus_write(reg.addr + k, byte)


def read_reg(backend: Backend, reg: Register) -> int:
    return reg.from_bytes([backend.bus_read(reg.addr + k) for k in range(reg.nbytes)])


def firmware(backend: Backend, cycles: int, moves: int | None = None) -> tuple[int, list]:
    """Run moves for ``cycles`` (or ``moves`` moves); returns the cycles and end positions."""
    positions: list[tuple[int, int]] = []
    start = backend.cycle
    while backend.cycle - start < cycles and len(positions) != moves:
        move = len(positions) + 1
        write_reg(backend, MAP["DX"], 397 * move % 6001 - 3000)
        write_reg(backend, MAP["DY"], 691 * move % 4001 - 2000)
        write_reg(backend, MAP["FEED"], 0x4000 + 977 * move % 0x8000)
        write_reg(backend, MAP["START"], 1)
        backend.run_until("irq", 100_000)
        read_reg(backend, MAP["STATUS"])
        positions.append((read_reg(backend, MAP["X"]), read_reg(backend, MAP["Y"])))
    return backend.cycle - start, positions


SPEEDS: dict[str, float] = {}
CYCLES = {"pysim": 20_000, "cxxrtl": 5_000_000}


@pytest.mark.parametrize("kind", ["pysim", "cxxrtl"])
def test_firmware_loop_cycles_per_second(benchmark, kind, capsys):
    backend = PysimBackend(BenchChip()) if kind == "pysim" else CxxrtlBackend(BenchChip())
    runs = []

    def run():
        backend.reset()
        start = time.perf_counter()
        cycles, positions = firmware(backend, CYCLES[kind])
        runs.append((cycles / (time.perf_counter() - start), positions))

    benchmark.pedantic(run, rounds=3, iterations=1)
    backend.close()
    SPEEDS[kind] = max(speed for speed, _ in runs)
    benchmark.extra_info["cycles_per_second"] = SPEEDS[kind]
    # The backends agree: the first moves end at the same positions on Amaranth's simulator.
    _, positions = runs[0]
    assert firmware(PysimBackend(BenchChip()), CYCLES["pysim"], moves=3)[1] == positions[:3]
    if len(SPEEDS) == 2:
        with capsys.disabled():
            print()
            for name, speed in SPEEDS.items():
                print(f"{name:>7}: {speed:12,.0f} cycles/s (IRQ-driven firmware loop)")
            print(f"  ratio: {SPEEDS['cxxrtl'] / SPEEDS['pysim']:12,.0f} x")
