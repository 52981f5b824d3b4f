"""Reference model of the KM3702 position controller (``docs/chips/k3702.md``), in plain Python.

One :meth:`K3702Model.step` is one clock cycle: the falling edge inside it (where the chip's
counters and flags change) and the rising edge that ends it (where the host bus acts). The
gateware :class:`k37.hdl.k3702.chip.K3702` matches it cycle by cycle.
"""

from __future__ import annotations

from dataclasses import dataclass

from k37.hdl.bus.model.hostbus import RegisterBankModel
from k37.hdl.k3702.map import COUNTER_WIDTH, K3702_MAP

__all__ = ["K3702Model", "K3702Outputs", "wrap"]

_CMD = K3702_MAP["CMD"]
_STATUS = K3702_MAP["STATUS"]


def wrap(value: int, width: int = COUNTER_WIDTH) -> int:
    """``value`` as a ``width``-bit two's complement counter holds it (silent wraparound)."""
    half = 1 << (width - 1)
    return (value + half) % (2 * half) - half


@dataclass(frozen=True)
class K3702Outputs:
    """The chip's outputs after a cycle's falling edge (what the next cycle shows)."""

    command: int
    error: int
    dac: int
    sat_pos: int
    sat_neg: int
    in_position: int
    negative: int
    alarm_n: int
    irq: int
    #: The STATUS register byte.
    status: int


class K3702Model:
    """One KM3702, one clock cycle per :meth:`step`.

    Host writes go through :meth:`write` with the same timing as the bus (see
    :class:`~k37.hdl.bus.model.hostbus.RegisterBankModel`): a write issued before step *t* acts in
    step *t* + 1.
    """

    def __init__(self) -> None:
        self.bank = RegisterBankModel(K3702_MAP)
        self._bad_config = 0
        self.outputs = self._evaluate(0, 0, irq=0)

    def write(self, name: str, value: int) -> None:
        """Let the host write register ``name`` (its committing byte) in the coming cycle."""
        self.bank.write(name, value)

    def step(self, com_pos: int = 0, com_neg: int = 0, fb_pos: int = 0,
             fb_neg: int = 0) -> K3702Outputs:
        """Run one cycle with these count inputs; return the outputs the next cycle shows."""
        bank, old = self.bank, self.outputs
        cmd = bank.values["CMD"] if bank.w_stb("CMD") else 0

        def command_bit(name: str) -> int:
            return _CMD.field(name).decode(cmd)

        def base(counter: str, current: int) -> int:
            if bank.w_stb(counter):
                return bank.values[counter]
            return 0 if command_bit(f"clear_{counter.lower()}") else current

        # The host's correction pulses count as command pulses (K37's extension).
        com = com_pos - com_neg + (bank.values["CORRECT"] if bank.w_stb("CORRECT") else 0)
        command = wrap(base("COMMAND", old.command) + com)
        error = wrap(base("ERROR", old.error) + com - fb_pos + fb_neg)
        alarm = int(abs(error) > bank.values["ALARM_ZONE"])
        # The interrupt is set on entry into the alarm zone and held until acknowledged.
        irq = int((old.irq and not command_bit("ack")) or (alarm and old.alarm_n))
        self._bad_config = int((self._bad_config and not command_bit("clear"))
                               or bank.w_err("DAC_BITS"))
        self.outputs = self._evaluate(command, error, irq)
        bank.clock()
        return self.outputs

    def _evaluate(self, command: int, error: int, irq: int) -> K3702Outputs:
        """The outputs for new counter values under the current settings."""
        values = self.bank.values
        half = 1 << (values["DAC_BITS"] - 1)
        sat_pos, sat_neg = int(error >= half), int(error < -half)
        dac = 2 * half - 1 if sat_pos else 0 if sat_neg else error + half
        in_position = int(abs(error) <= values["POSITION_ZONE"])
        alarm = int(abs(error) > values["ALARM_ZONE"])
        negative = int(error < 0)
        status = _STATUS.encode(in_position=in_position, negative=negative, sat_pos=sat_pos,
                                sat_neg=sat_neg, alarm=alarm, irq=irq,
                                bad_config=self._bad_config)
        return K3702Outputs(command=command, error=error, dac=dac, sat_pos=sat_pos,
                            sat_neg=sat_neg, in_position=in_position, negative=negative,
                            alarm_n=1 - alarm, irq=irq, status=status)
