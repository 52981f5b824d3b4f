"""Linear accel/decel circuit: a moving average of the pulse rate over T = 2**n / fa.

The reference model is :class:`k37.hdl.accel.model.linear.AccelLinearModel` (which explains the
circuit and why no pulse is lost).
"""

from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal

from k37.hdl.accel.exponential import AccelCircuit, accel_members, carry_and_pulses
from k37.hdl.accel.model.exponential import check_params
from k37.hdl.accel.model.linear import check_bins
from k37.hdl.common.observation import FreeRunning

__all__ = ["AccelLinear"]


class AccelLinear(AccelCircuit):
    """Linear accel/decel: ``fo(t) = (1/T) * (pulses in over the last T)``, ``T = 2**n / fa``.

    A window of ``2**bins_bits`` bins of ``2**(n - bins_bits)`` additions each holds the input
    pulses of the last T; on each addition the accumulator takes ``y + x`` (``x`` the window's
    count) modulo ``2**n`` and its carry is owed as output pulses, sent one per cycle. The
    window moves a bin at a time, so the output follows the true moving average with a delay
    of up to one bin (T / 16 at the default ``bins_bits``).

    Cycle timing: the addition of cycle *t* uses ``x`` and ``y`` of cycle *t*; an input pulse
    of cycle *t* is counted in the open bin from cycle *t* + 1 (in the new bin if the addition
    of cycle *t* closes one); the bin that closes at an addition enters ``x`` from the next
    cycle. The carry's pulses leave one per cycle from cycle *t* + 1 on, behind any pulses
    still pending (latency 1 cycle from ``add`` to the first output pulse when nothing was
    pending). An input pulse and an output pulse in the same cycle are both applied (glitch
    free). Counts wrap modulo ``2**counter_width`` like the real counters.

    Parameters
    ----------
    n : int
        Accumulator width in bits: T = 2**n additions (default 15, the paper's, T = 300 ms).
    counter_width : int
        Width of the bins, the window count ``x``, the open bin and ``pending`` (default 24).
    bidirectional : bool
        False: the pre-interpolation circuit (ports ``inp``/``out``). True: one axis's
        post-interpolation circuit (``inp_pos``/``inp_neg``/``out_pos``/``out_neg``), signed
        counts.
    bins_bits : int
        log2 of the number of bins in the window, 0..n (default 4: 16 bins).

    Members
    -------
    inp : In(1), unidirectional
        Input pulse fi.
    inp_pos, inp_neg : In(1), bidirectional
        Signed input pulses; both high in one cycle count +1 and -1.
    add : In(1)
        Addition clock fa (a one-cycle clock enable).
    out : Out(1), unidirectional
        Output pulse, high in a cycle iff ``pending`` > 0 in it (a registered state).
    out_pos, out_neg : Out(1), bidirectional
        ``out_pos`` iff ``pending > 0``, ``out_neg`` iff ``pending < 0``.
    x : Out(counter_width) (signed when bidirectional)
        Probe: the window count (pulses in the closed bins).
    y : Out(n)
        Probe: the accumulator.
    pending : Out(counter_width) (signed when bidirectional)
        Probe: output pulses owed and not yet sent.
    idle : Out(1)
        Drained: no pulse in any bin, none pending; the circuit is then static.

    Simulation only (see :mod:`k37.hdl.common.observation`)
    --------------------------------------------
    quiet : Signal(1)
        ``idle``: a drained circuit changes no register until its next input pulse.
    free_running : FreeRunning
        None: the circuit runs on only while it holds pulses, and is not quiet then.
    """

    def __init__(self, n: int = 15, counter_width: int = 24, bidirectional: bool = False,
                 bins_bits: int = 4):
        check_params(n, counter_width, bidirectional)
        check_bins(n, bins_bits)
        self.n = n
        self.counter_width = counter_width
        self.bidirectional = bidirectional
        self.bins_bits = bins_bits
        super().__init__(accel_members(n, counter_width, bidirectional))
        self.quiet = Signal()

    @staticmethod
    def declare(n: int, bidirectional: bool) -> FreeRunning:  # noqa: ARG004 (the family's call)
        """The free-running declaration (nothing but ``quiet``), as
        :meth:`k37.hdl.accel.exponential.AccelDecel.declare`."""
        return FreeRunning(quiet="quiet")

    def elaborate(self, platform) -> Module:
        m = Module()
        count = 1 << self.bins_bits
        bins = [Signal(self.x.shape(), name=f"bin{k}") for k in range(count)]  # bin0 is oldest
        open_bin = Signal(self.x.shape())
        tick = Signal(self.n - self.bins_bits)
        live = Signal(range(count + 1))
        active = Signal()
        m.d.comb += active.eq((open_bin != 0) | (live != 0))

        total, carry, net_in, net_out = carry_and_pulses(m, self)
        m.d.sync += [self.pending.eq(self.pending - net_out + carry),
                     open_bin.eq(open_bin + net_in)]
        with m.If(self.add):
            m.d.sync += self.y.eq(total)
            with m.If(active):
                with m.If(tick == (1 << len(tick)) - 1 if len(tick) else 1):
                    m.d.sync += [Cat(*bins).eq(Cat(*bins[1:], open_bin)),
                                 self.x.eq(self.x + open_bin - bins[0]),
                                 live.eq(Mux(open_bin != 0, count, live - 1)),
                                 open_bin.eq(net_in)]
                    if len(tick):
                        m.d.sync += tick.eq(0)
                with m.Else():
                    m.d.sync += tick.eq(tick + 1)
        m.d.comb += [self.idle.eq(~active & (self.pending == 0)), self.quiet.eq(self.idle)]
        return m
