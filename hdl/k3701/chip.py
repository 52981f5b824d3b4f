"""KM3701 interpolator gateware.

The chip's ports, parameters and timing; its logic is the shared core
(:mod:`k37.hdl.k3701.core`) composed with the two-axis (:mod:`k37.hdl.k3701.two_axis`) or the
three-axis (:mod:`k37.hdl.k3701.three_axis`) datapaths. The reference model is
:mod:`k37.hdl.k3701.model.chip`; this chip is tested against it cycle by cycle.
"""

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.bus.hostbus import HostBus
from k37.hdl.common.constants import ALL_AXES
from k37.hdl.common.observation import Countdown, FreeRunning, Observed
from k37.hdl.k3701.block import CIRCLE_SETUP_CYCLES, LATENCY_CIRCULAR, LATENCY_LINEAR, Kind
from k37.hdl.k3701.core import K3701Core
from k37.hdl.k3701.map import k3701_map
from k37.hdl.k3701.three_axis import ThreeAxes
from k37.hdl.k3701.two_axis import DATAPATHS, TwoAxes

__all__ = ["K3701"]


class K3701(Observed, wiring.Component):
    """The KM3701 two-axis interpolator.

    The host loads a block through :data:`K3701_MAP` and writes ``CMD.start``; each feed pulse
    earns step credit and each step emits one-cycle pulses on the axes it moves. Timing is
    that of :class:`k37.hdl.k3701.model.chip.K3701Model` (S is the cycle after the host's write of
    the start command):

    * linear: BUSY and FP intake from S+1; circular: BUSY from S+1, a serial radius check
      until S+``circle_setup``, FP intake from S+1+``circle_setup``; parabolic: the same
      with its setup of ``PARABOLA_SETUP_CYCLES`` (29) cycles and the circular latency;
      exponential: likewise with ``EXPONENTIAL_SETUP_CYCLES`` (4);
    * a step's pulses appear exactly ``latency_*`` cycles after the FP that completes its
      credit (2 half-FP per FP; a step costs 2, a diagonal one 3 with sqrt(2) control);
      one FP arriving meanwhile is held, a further one sets OVERRUN and is lost;
    * BUSY falls and ``irq`` rises in the cycle of the final step's pulses.

    Inside, the core (:class:`k37.hdl.k3701.core.K3701Core`) runs the block (registers, commands
    and status, FP intake and credit, the pulses), its step latency count times the steps and
    the datapaths' stages (:mod:`k37.hdl.k3701.latency`), and one datapath per interpolation
    type decides its steps (:mod:`k37.hdl.k3701.datapaths`, through the interface of
    :mod:`k37.hdl.k3701.datapaths.base`). Each step is decided before its FP can come: a line's
    next step in the cycle the current one is output, a circle's first step during the radius
    check and each following one in four pipelined cycles of the current step's latency. The
    logic thus works only when there is something to decide, which keeps compiled simulation
    fast; it needs a circular latency of at least 6 cycles.

    Parameters
    ----------
    latency_linear, latency_circular : int
        Cycles from the credit-completing FP to the step pulses (paper: 11 and 21 at 1 MHz);
        2..32 linear, 6..32 circular (also the parabolic and exponential latency).
    circle_setup : int
        Cycles of the circular radius check; must equal 25 (24 squarer cycles plus the check).
    axes : int
        2 (the paper's chip) or 3: the three-axis build (:data:`K3701_MAP_3`) steps lines in
        X, Y and Z (:class:`k37.hdl.k3701.datapaths.linear.LinearDatapath3`), routes a block's axes
        to the machine's by CTRL.plane (an arc, a parabola or an exponential runs in the plane's two
        axes, a curve's modes in MODE) and moves a helix's third axis with the arc's steps
        (:class:`k37.hdl.k3701.datapaths.helix.HelixAxis`); its FP credit is in quarter-FP units (a
        step moving 1, 2, 3 axes costs 1, 1.5, 1.75 FP with sqrt(2) control), the same timing as the
        two-axis chip for blocks without a third axis.

    Members
    -------
    bus : In(HostBus(k3701_map(axes).addr_width))
        Host interface (see :mod:`k37.hdl.bus.hostbus` for its cycle timing).
    fp : In(1)
        Feed pulse, sampled every cycle; each cycle it is high counts as one FP.
    x_pos, x_neg, y_pos, y_neg : Out(1)
        One-cycle step pulses; a diagonal step pulses both axes in the same cycle.
    z_pos, z_neg : Out(1)
        Three-axis chip only: the Z axis's step pulses, likewise.
    busy : Out(1)
        A block is running (STATUS.busy).
    irq : Out(1)
        Data-request interrupt; rises when a block ends (also with ERROR), held until CMD.ack.
    error, overrun : Out(1)
        The sticky STATUS bits.

    Simulation only (attributes, not pins: see :mod:`k37.hdl.common.observation`)
    ----------------------------------------------------------------
    quiet : Signal(1)
        While no FP comes, the step latency count affects nothing but its own decrement each
        cycle until it reaches 1: FP is low, and the count is 0 (waiting for FP) or at least
        2 and past the running datapath's decision stages; combinational.
    free_running : FreeRunning
        The latency count (``latency.count``, of :class:`k37.hdl.k3701.latency.StepLatency`), a
        :class:`k37.hdl.common.observation.Countdown` that stops before 1.
    """

    def __init__(self, *, latency_linear: int = LATENCY_LINEAR,
                 latency_circular: int = LATENCY_CIRCULAR,
                 circle_setup: int = CIRCLE_SETUP_CYCLES, axes: int = 2):
        if axes not in (2, 3):
            raise ValueError(f"axes must be 2 or 3, not {axes!r}")
        for name, value, kind in (("latency_linear", latency_linear, Kind.LINEAR),
                                  ("latency_circular", latency_circular, Kind.CIRCULAR)):
            low = 2 + DATAPATHS[kind].STAGES
            if not isinstance(value, int) or not low <= value <= 32:
                raise ValueError(f"{name} must be an integer in {low}..32, not {value!r}")
        if circle_setup != CIRCLE_SETUP_CYCLES:
            raise ValueError(f"circle_setup must be {CIRCLE_SETUP_CYCLES} (24 squarer cycles "
                             f"and the check), not {circle_setup!r}")
        self.latency_linear = latency_linear
        self.latency_circular = latency_circular
        self.circle_setup = circle_setup
        self.axes = axes
        self.regmap = k3701_map(axes)
        super().__init__({
            "bus": In(HostBus(self.regmap.addr_width)), "fp": In(1),
            **{f"{a}_{d}": Out(1) for a in ALL_AXES[:axes] for d in ("pos", "neg")},
            "busy": Out(1), "irq": Out(1), "error": Out(1), "overrun": Out(1),
        })
        self.quiet = Signal()

    @property
    def free_running(self) -> FreeRunning:
        """See "Simulation only" above."""
        return self.declare()

    @staticmethod
    def declare() -> FreeRunning:
        """The free-running declaration of any K3701 (no instance needed: a parent declares
        it before it builds the chip)."""
        return FreeRunning(countdowns=(Countdown("latency.count", stop=1),), quiet="quiet")

    def elaborate(self, platform) -> Module:
        return K3701Core(self, ThreeAxes() if self.axes == 3 else TwoAxes()).elaborate()
