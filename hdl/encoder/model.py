"""Reference model of the encoder interface (``docs/chips/encoder.md``), in plain Python.

One :meth:`EncoderModel.step` is one sample: the inputs of a clock cycle and the rising edge
that ends it. The gateware :class:`k37.hdl.encoder.chip.EncoderInterface` matches it cycle by cycle.
"""

from __future__ import annotations

from k37.hdl.bus.model.hostbus import RegisterBankModel
from k37.hdl.encoder.map import ENCODER_MAP, Decode

__all__ = ["EncoderModel"]

_CLEAR = ENCODER_MAP["CMD"].field("clear")
_DECODE = ENCODER_MAP["MODE"].field("decode")
_STATUS = ENCODER_MAP["STATUS"]
_X1, _X4 = int(Decode.X1), int(Decode.X4)  # plain ints: the model runs 10^6-edge streams


class _Line:
    """One differential line (A or B): receiver, line-fault detector and glitch filter."""

    def __init__(self) -> None:
        self.received = 0  # receiver output, held while the pair carries no difference
        self.level = 0     # the filter's accepted level
        self.fault = 0
        self._broken = 0   # non-complementary samples in a row (restarts after K)
        self._run = 0      # samples in a row differing from the accepted level

    def sample(self, line: int, line_n: int, k: int, started: bool, clear: bool) -> bool:
        """Take one sample; True when the filter accepts a new level."""
        # Receiver and line-fault detector: K non-complementary samples in a row are a fault.
        if line != line_n:
            self.received = line
            self._broken = 0
            broken = False
        else:
            broken = self._broken + 1 >= k
            self._broken = 0 if broken else self._broken + 1
        if broken or clear:
            self.fault = int(broken)
        # Glitch filter: a new level is accepted on the K-th differing sample in a row. The
        # first sample after reset sets the level without a change.
        if not started:
            self.level = self.received
            return False
        if self.received == self.level:
            self._run = 0
            return False
        if self._run + 1 < k:
            self._run += 1
            return False
        self._run = 0
        self.level = self.received
        return True


class EncoderModel:
    """One encoder interface, one sample per :meth:`step`.

    Host writes go through :meth:`write` with the bus timing (see
    :class:`~k37.hdl.bus.model.hostbus.RegisterBankModel`): a write issued before step *t* acts from
    step *t* + 1 on.
    """

    def __init__(self) -> None:
        self.bank = RegisterBankModel(ENCODER_MAP)
        self.a = _Line()
        self.b = _Line()
        self._started = False
        self._quad_error = 0
        self._bad_config = 0

    def write(self, name: str, value: int) -> None:
        """Let the host write register ``name`` (its committing byte) in the coming cycle."""
        self.bank.write(name, value)

    def step(self, a: int, a_n: int, b: int, b_n: int) -> int:
        """Take one sample of the four lines; return the FB pulse the next cycle shows.

        +1 is a ``fb_pos`` pulse, -1 a ``fb_neg`` pulse, 0 none.
        """
        # This cycle's settings and strobes; then the edge that ends the cycle (the bank takes
        # this cycle's bus write) and the samples taken at it.
        bank = self.bank
        values = bank.values
        k, mode = values["FILTER"], values["MODE"]
        clear = bank.w_stb("CMD") and bool(_CLEAR.decode(values["CMD"]))
        rejected = bank.w_err("FILTER") or bank.w_err("MODE")
        bank.clock()
        change_a = self.a.sample(a, a_n, k, self._started, clear)
        change_b = self.b.sample(b, b_n, k, self._started, clear)
        self._started = True
        # Sticky flags: a flag set in a sample survives a clear in that sample.
        if rejected or clear:
            self._bad_config = int(rejected)
        both = change_a and change_b  # an illegal transition: flagged, not counted
        if both or clear:
            self._quad_error = int(both)
        if change_a == change_b:
            return 0

        decode = _DECODE.decode(mode)
        if decode != _X4 and (change_b or (decode == _X1 and self.b.level)):
            return 0  # x2 counts only A edges, x1 only the A edges while B is low
        # After a change of A, A != B means A leads (+FB); after a change of B, A == B does.
        up = self.a.level != self.b.level if change_a else self.a.level == self.b.level
        return 1 if up else -1

    @property
    def line_fault(self) -> int:
        """The ``line_fault`` output the next cycle shows."""
        return self.a.fault | self.b.fault

    @property
    def quad_error(self) -> int:
        """The ``quad_error`` output the next cycle shows."""
        return self._quad_error

    @property
    def status(self) -> int:
        """The STATUS byte the next cycle shows."""
        return _STATUS.encode(line_fault_a=self.a.fault, line_fault_b=self.b.fault,
                              quad_error=self._quad_error, bad_config=self._bad_config,
                              a=self.a.level, b=self.b.level)
