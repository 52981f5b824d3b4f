"""Exponential accel/decel circuit: up/down counter plus accumulator (``docs/chips/accel.md``).

The reference model is :class:`k37.hdl.accel.model.exponential.AccelDecelModel`.
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal, signed, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.accel.model.exponential import check_params
from k37.hdl.common.observation import CarryAccumulator, FreeRunning, Observed

__all__ = ["AccelCircuit", "AccelDecel", "accel_members", "carry_and_pulses"]


def accel_members(n: int, counter_width: int, bidirectional: bool) -> dict[str, wiring.Member]:
    """The signature every accel/decel circuit has (exponential, linear, bell): its pulse
    ports (one line, or a signed pair with ``bidirectional``), ``add``, and the observation
    outputs ``x``, ``y``, ``pending`` and ``idle``."""
    shape = signed(counter_width) if bidirectional else unsigned(counter_width)
    pulses = ({"inp_pos": In(1), "inp_neg": In(1), "out_pos": Out(1), "out_neg": Out(1)}
              if bidirectional else {"inp": In(1), "out": Out(1)})
    return {**pulses, "add": In(1), "x": Out(shape), "y": Out(n), "pending": Out(shape),
            "idle": Out(1)}


def carry_and_pulses(m: Module, circuit: wiring.Component):
    """What every accel/decel circuit of this family shares: the addition ``y + x`` of an
    ``n``-bit accumulator, its carry (0 in a cycle without ``add``), the output pulses from
    ``pending`` and the net input and output pulses. Returns (total, carry, net_in, net_out);
    the circuit updates its registers from them."""
    total = Signal((circuit.y + circuit.x).shape())
    carry = Signal((total >> circuit.n).shape())
    m.d.comb += [total.eq(circuit.y + circuit.x),
                 carry.eq(Mux(circuit.add, total >> circuit.n, 0))]
    if circuit.bidirectional:
        m.d.comb += [circuit.out_pos.eq(circuit.pending > 0),
                     circuit.out_neg.eq(circuit.pending < 0)]
        return (total, carry, circuit.inp_pos - circuit.inp_neg,
                circuit.out_pos - circuit.out_neg)
    m.d.comb += circuit.out.eq(circuit.pending != 0)
    return total, carry, circuit.inp, circuit.out


class AccelCircuit(Observed, wiring.Component):
    """What every accel/decel circuit tells a simulator: its probes ``x``, ``y`` and
    ``pending``, and its free-running state, the :meth:`declare` of its class for its ``n``
    and ``bidirectional``."""

    n: int
    bidirectional: bool

    @property
    def probes(self) -> tuple[str, ...]:
        """Observation outputs, not pins of the chip (the Verilog export keeps them inside)."""
        return ("x", "y", "pending")

    @property
    def free_running(self) -> FreeRunning:
        """The class's :meth:`declare` for this circuit's parameters."""
        return self.declare(self.n, self.bidirectional)

    @staticmethod
    def declare(n: int, bidirectional: bool) -> FreeRunning:
        """The free-running declaration of a circuit with these parameters (no instance
        needed: a parent declares it before it builds the circuit)."""
        raise NotImplementedError


class AccelDecel(AccelCircuit):
    """Exponential accel/decel: ``fo = fi (1 - exp(-t / tau))``, ``tau = 2**n / fa``.

    Input pulses count the up/down counter ``x`` up. In a cycle with ``add`` high the
    accumulator takes ``y + x`` modulo ``2**n`` and the carry ``c = (y + x) >> n`` is
    subtracted from ``x`` and added to the pending-output counter, which sends one output
    pulse per cycle until it is empty. An input pulse and a carry in the same cycle are both
    applied (the paper's input separation and glitch prevention), so at every cycle
    ``inputs = outputs + x + pending``: after the input stops and the circuit drains, the
    output count equals the input count exactly.

    The addition clock fa comes from outside (a :class:`k37.hdl.feed.divider.PhaseDivider` with
    ``k37.hdl.feed.rates.FA_INCREMENT`` gives the paper's 109.227 kHz, tau = 300 ms at n =
    15), so one divider can serve several circuits and tests can drive ``add`` freely.

    Cycle timing: the addition of cycle *t* uses ``x`` and ``y`` of cycle *t* (an input
    pulse of cycle *t* is counted in ``x`` from cycle *t* + 1, not in that addition); all
    registers update at the edge ending cycle *t*. The carry's pulses leave one per cycle from
    cycle *t* + 1 on, behind any pulses still pending: latency 1 cycle from ``add`` to the
    first output pulse when nothing was pending. ``x`` and ``pending`` wrap modulo
    ``2**counter_width`` (two's complement when bidirectional) if more than that many pulses
    are in flight, like the real counter; the paper's highest feed keeps it far below
    (fi * tau = 1 MHz * 300 ms = 3e5 < 2**23).

    Parameters
    ----------
    n : int
        Accumulator width in bits (default 15, the paper's value).
    counter_width : int
        Width of the up/down counter ``x`` and of ``pending`` (default 24).
    bidirectional : bool
        False (default): the pre-interpolation circuit that feeds FP, ports ``inp``/``out``.
        True: the post-interpolation circuit of one axis between the K3701 and its K3702,
        ports ``inp_pos``/``inp_neg``/``out_pos``/``out_neg``; ``x`` and ``pending`` are
        signed and the carry is the floor of ``(y + x) / 2**n`` (a borrow when ``x < 0``).

    Members
    -------
    inp : In(1), unidirectional
        Input pulse fi: each cycle it is high counts once.
    inp_pos, inp_neg : In(1), bidirectional
        Signed input pulses; both high in one cycle count +1 and -1 (no net change).
    add : In(1)
        Addition clock fa (a one-cycle clock enable).
    out : Out(1), unidirectional
        Output pulse fo, high in a cycle iff ``pending`` > 0 in it (a registered state).
    out_pos, out_neg : Out(1), bidirectional
        Output pulse with sign: ``out_pos`` iff ``pending > 0``, ``out_neg`` iff ``pending < 0``.
    x : Out(counter_width) (signed when bidirectional)
        Probe: the up/down counter, after the carries already taken out.
    y : Out(n)
        Probe: the accumulator.
    pending : Out(counter_width) (signed when bidirectional)
        Probe: output pulses owed and not yet sent.
    idle : Out(1)
        Drained: ``x == 0`` and ``pending == 0`` (``y`` keeps its residue).

    Simulation only (see :mod:`k37.hdl.common.observation`)
    --------------------------------------------
    quiet : Signal(1)
        No output pulse pending: until the accumulator's next carry only ``y`` changes.
    free_running : FreeRunning
        The accumulator, adding ``x`` at each ``add`` (its clock named by the parent).
    """

    def __init__(self, n: int = 15, counter_width: int = 24, bidirectional: bool = False):
        check_params(n, counter_width, bidirectional)
        self.n = n
        self.counter_width = counter_width
        self.bidirectional = bidirectional
        super().__init__(accel_members(n, counter_width, bidirectional))
        self.quiet = Signal()

    @staticmethod
    def declare(n: int, bidirectional: bool) -> FreeRunning:
        """The free-running declaration of a circuit with these parameters (no instance
        needed: a parent declares it before it builds the circuit)."""
        return FreeRunning(carries=(CarryAccumulator("", n, bidirectional),), quiet="quiet")

    def elaborate(self, platform) -> Module:
        m = Module()
        total, carry, net_in, net_out = carry_and_pulses(m, self)
        with m.If(self.add):
            m.d.sync += self.y.eq(total)
        m.d.sync += [self.x.eq(self.x - carry + net_in),
                     self.pending.eq(self.pending - net_out + carry)]
        m.d.comb += [self.idle.eq((self.x == 0) & (self.pending == 0)),
                     self.quiet.eq(self.pending == 0)]
        return m
