"""Decel control: the host-loaded FP budget gate before the accel/decel circuit
(``docs/chips/decel.md``).

The reference model is :class:`k37.hdl.feed.model.decel_control.DecelControlModel`.
"""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from k37.hdl.bus.hostbus import HostBus, RegisterBank
from k37.hdl.common.observation import Observed
from k37.hdl.feed.map.decel_control import DECEL_MAP
from k37.hdl.feed.rates import BUDGET_WIDTH

__all__ = ["DecelControl"]

class DecelControl(Observed, wiring.Component):
    """The FP budget gate: passes exactly the loaded number of input pulses, then closes.

    The host writes BUDGET (the FP count the block needs, from the firmware model's exact
    count); input pulses pass to ``out`` and count REMAINING down; when it reaches 0 the gate
    is closed (``spent``) and the accel/decel circuit behind it drains, so the K3701 receives
    exactly the budget and the axis decelerates into the end point. CTRL.hold closes the gate
    at once (the alarm routine's stop feed) and keeps REMAINING for a later resume. After
    reset REMAINING is 0: nothing passes until a budget is loaded.

    Members
    -------
    bus : In(HostBus(DECEL_MAP.addr_width))
        Host bus (register map ``DECEL_MAP``). A BUDGET or CTRL write takes effect in the
        cycle after its committing byte (the bank's ``w_stb`` cycle); an input pulse in that
        cycle already sees the new budget and hold bit.
    inp : In(1)
        Input feed pulses (from the rate multiplier); each cycle it is high is one pulse.
    out : Out(1)
        Passed pulse, combinational: ``inp`` while the gate is open.
    gate_open : Out(1)
        The gate passes an input pulse in this cycle: not held and REMAINING > 0 (counting a
        BUDGET that takes effect in this cycle); combinational.
    spent : Out(1)
        REMAINING == 0; rises in the cycle after the last pulse passes (registered state).
    remaining : Out(24)
        Probe: the remaining budget (what REMAINING reads).
    """

    @property
    def probes(self) -> tuple[str, ...]:
        """Observation outputs, not pins of the chip (the Verilog export keeps them inside)."""
        return ("remaining",)

    bus: In(HostBus(DECEL_MAP.addr_width))
    inp: In(1)
    out: Out(1)
    gate_open: Out(1)
    spent: Out(1)
    remaining: Out(BUDGET_WIDTH)

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.regs = regs = RegisterBank(DECEL_MAP)
        connect(m, flipped(self.bus), regs.bus)

        hold = regs.ctrl.w_data[DECEL_MAP["CTRL"].field("hold").offset]
        current = Signal(BUDGET_WIDTH)
        m.d.comb += [
            current.eq(Mux(regs.budget.w_stb, regs.budget.w_data, self.remaining)),
            self.gate_open.eq(~hold & (current != 0)),
            self.out.eq(self.inp & self.gate_open),
            self.spent.eq(self.remaining == 0),
        ]
        m.d.sync += self.remaining.eq(current - self.out)

        m.d.comb += [regs.remaining.r_data.eq(self.remaining),
                     regs.ctrl.r_data.eq(regs.ctrl.w_data)]
        for name, value in (("spent", self.spent), ("open", ~self.spent & ~hold)):
            m.d.comb += regs.status.r_data[DECEL_MAP["STATUS"].field(name).offset].eq(value)
        return m
