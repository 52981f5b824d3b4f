"""The encoder interface's registers as the host sees them
(:class:`k37.hdl.encoder.chip.EncoderInterface` implements them)."""

from __future__ import annotations

import enum

from k37.hdl.bus.registers import Access, Field, Register, RegisterMap

__all__ = ["ENCODER_MAP", "FILTER_INIT", "Decode"]

#: Glitch-filter length after reset. A 3-sample digital filter is what the quadrature
#: decoder ICs of the paper's time used (e.g. HP's HCTL-2000 family: a level must be stable
#: for three clock edges); at 1 MHz it rejects glitches up to 2 us and passes edges up to
#: 333 k/s.
FILTER_INIT = 3


class Decode(enum.IntEnum):
    """MODE.decode: counts per encoder cycle (4 edges)."""

    #: One count per cycle, on the A edge while B is low (forward: A rises; reverse: A falls).
    X1 = 0
    #: Two counts per cycle, on every A edge.
    X2 = 1
    #: Four counts per cycle, on every A and B edge.
    X4 = 2


ENCODER_MAP = RegisterMap("ENCODER", 1, (
    Register("FILTER", 0x0, 8, Access.RW,
             "K: a level is accepted after K consecutive equal samples, and a pair that is not "
             "complementary for K consecutive samples is a line fault (reads back)",
             init=FILTER_INIT, valid=(1, 255)),
    Register("MODE", 0x1, 8, Access.RW, "decoding mode (reads back)",
             fields=(Field("decode", 0, 2, "0: x1, 1: x2, 2: x4"),),
             init=int(Decode.X4), valid=(0, int(Decode.X4))),
    Register("STATUS", 0x2, 8, Access.R, "flags and the filtered line levels",
             after_reset=0, fields=(
        Field("line_fault_a", 0, 1, "A and /A were equal for K samples (sticky until "
                                    "CMD.clear)"),
        Field("line_fault_b", 1, 1, "B and /B likewise"),
        Field("quad_error", 2, 1, "A and B changed in the same sample; not counted (sticky)"),
        Field("bad_config", 3, 1, "a FILTER or MODE write out of range was ignored (sticky)"),
        Field("a", 4, 1, "filtered level of A"),
        Field("b", 5, 1, "filtered level of B"),
    )),
    Register("CMD", 0x3, 8, Access.W, "commands, acted on in the cycle after the write",
             fields=(Field("clear", 0, 1, "clear the sticky STATUS flags (a flag set in the "
                                          "same cycle stays set)"),)),
), doc="Encoder interface: differential receiver, glitch filter and quadrature decoder.")
