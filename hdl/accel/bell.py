"""Bell-shaped accel/decel circuit: the linear circuit, then the exponential one.

The reference model is :class:`k37.hdl.accel.model.bell.AccelBellModel`.
"""

from __future__ import annotations

from amaranth.hdl import Module, Signal

from k37.hdl.accel.exponential import AccelCircuit, AccelDecel, accel_members
from k37.hdl.accel.linear import AccelLinear
from k37.hdl.accel.model.exponential import check_params
from k37.hdl.accel.model.linear import check_bins
from k37.hdl.common.observation import FreeRunning

__all__ = ["AccelBell"]


class AccelBell(AccelCircuit):
    """Bell accel/decel (the filters paper's eq. (40)): :class:`k37.hdl.accel.linear.AccelLinear`
    (moving average over T = 2**n / fa) feeding :class:`k37.hdl.accel.exponential.AccelDecel`
    (tau = 2**n / fa).

    Cycle timing: an output pulse of the linear stage in cycle *t* is an input pulse of the
    exponential stage in cycle *t* (combinational), so each stage's timing holds as it is
    documented there; both take the same ``add``.

    Parameters
    ----------
    n, counter_width, bidirectional, bins_bits
        As :class:`k37.hdl.accel.linear.AccelLinear` (both stages have the same n).

    Members
    -------
    inp : In(1), unidirectional
        Input pulse fi (into the linear stage).
    inp_pos, inp_neg : In(1), bidirectional
        Signed input pulses; both high in one cycle count +1 and -1.
    out : Out(1), unidirectional
        Output pulse (the exponential stage's).
    out_pos, out_neg : Out(1), bidirectional
        Signed output pulses (the exponential stage's).
    add : In(1)
        Addition clock fa of both stages.
    x, y, pending : Out
        Probes: the exponential stage's counter, accumulator and pending count.
    idle : Out(1)
        Both stages drained.

    Simulation only (see :mod:`k37.hdl.common.observation`)
    --------------------------------------------
    quiet : Signal(1)
        Both stages quiet: the linear one drained, the exponential one with nothing pending.
    free_running : FreeRunning
        The exponential stage's accumulator (submodule ``exponential``).
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
    def declare(n: int, bidirectional: bool) -> FreeRunning:
        """The exponential stage's accumulator, as
        :meth:`k37.hdl.accel.exponential.AccelDecel.declare`."""
        return AccelDecel.declare(n, bidirectional).under("exponential").merge(quiet="quiet")

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.linear = linear = AccelLinear(self.n, self.counter_width,
                                                   self.bidirectional, self.bins_bits)
        m.submodules.exponential = exp = AccelDecel(self.n, self.counter_width,
                                                    self.bidirectional)
        if self.bidirectional:
            m.d.comb += [linear.inp_pos.eq(self.inp_pos), linear.inp_neg.eq(self.inp_neg),
                         exp.inp_pos.eq(linear.out_pos), exp.inp_neg.eq(linear.out_neg),
                         self.out_pos.eq(exp.out_pos), self.out_neg.eq(exp.out_neg)]
        else:
            m.d.comb += [linear.inp.eq(self.inp), exp.inp.eq(linear.out),
                         self.out.eq(exp.out)]
        m.d.comb += [linear.add.eq(self.add), exp.add.eq(self.add),
                     self.x.eq(exp.x), self.y.eq(exp.y), self.pending.eq(exp.pending),
                     self.idle.eq(linear.idle & exp.idle),
                     self.quiet.eq(linear.quiet & exp.quiet)]
        return m
