"""FST waveforms: a VCD converted into GTKWave's compressed format with the FST library
itself (``pylibfst``, the ``fstapi`` that GTKWave, Verilator and Surfer's readers share), and
the declarations and time span of an FST file, read back with the same library.

Every backend writes VCD (Amaranth's writer, CXXRTL's); ``k37 run --vcd run.fst`` traces into
a temporary VCD beside the FST and converts it when the run ends, one pass, streaming: the
hierarchy, every alias (one FST handle per VCD identifier), every value change at its time.
"""

from __future__ import annotations

import multiprocessing
import re
import signal
from multiprocessing.connection import Connection
from pathlib import Path

from pylibfst import ffi, get_scopes_signals2, lib

__all__ = ["convert_in_child", "fst_signals", "fst_span", "vcd_to_fst"]

#: VCD time units and FST's power-of-ten exponents.
_UNITS = {"s": 0, "ms": -3, "us": -6, "ns": -9, "ps": -12, "fs": -15}
#: VCD ``$var`` types and FST's variable types (others are written as wires).
_TYPES = {"wire": lib.FST_VT_VCD_WIRE, "reg": lib.FST_VT_VCD_REG,
          "integer": lib.FST_VT_VCD_INTEGER, "string": lib.FST_VT_GEN_STRING}


class _Writer:
    """One FST file being written from a VCD's lines."""

    def __init__(self, path: Path):
        self.ctx = lib.fstWriterCreate(str(path).encode(), 1)
        if self.ctx == ffi.NULL:
            raise OSError(f"cannot create the FST file {path}")
        lib.fstWriterSetPackType(self.ctx, lib.FST_WR_PT_LZ4)
        self.handles: dict[str, tuple[int, int]] = {}  # VCD id -> (FST handle, width)

    def declare(self, words: list[str]) -> None:
        """One ``$var TYPE WIDTH ID NAME $end`` line, split."""
        kind, width, ident, name = words[1], int(words[2]), words[3], words[4]
        alias, _ = self.handles.get(ident, (0, 0))
        handle = lib.fstWriterCreateVar(self.ctx, _TYPES.get(kind, lib.FST_VT_VCD_WIRE),
                                        lib.FST_VD_IMPLICIT, width, name.encode(), alias)
        self.handles.setdefault(ident, (handle, width))

    def header(self, words: list[str]) -> None:
        """One header line (scopes, variables; the time scale is set by the caller)."""
        if words[0] == "$scope":
            lib.fstWriterSetScope(self.ctx, lib.FST_ST_VCD_MODULE, words[2].encode(), ffi.NULL)
        elif words[0] == "$upscope":
            lib.fstWriterSetUpscope(self.ctx)
        elif words[0] == "$var":
            self.declare(words)

    def change(self, line: str) -> None:
        """One value-change line: ``#t``, ``b0101 id``, ``s... id`` or ``1id``."""
        head = line[0]
        if head == "#":
            lib.fstWriterEmitTimeChange(self.ctx, int(line[1:]))
        elif head in "bB":
            bits, ident = line[1:].split()
            handle, width = self.handles[ident]
            pad = bits[0] if bits[0] in "xzXZ" else "0"
            lib.fstWriterEmitValueChange(self.ctx, handle, bits.rjust(width, pad).encode())
        elif head in "sS":
            text, ident = line[1:].split()
            data = text.encode()
            lib.fstWriterEmitVariableLengthValueChange(self.ctx, self.handles[ident][0], data,
                                                       len(data))
        elif head in "01xzXZ":
            ident = line[1:].strip()
            lib.fstWriterEmitValueChange(self.ctx, self.handles[ident][0], head.encode())
        # "$dumpvars", "$end", "$comment" and blank lines carry no change

    def close(self) -> None:
        lib.fstWriterClose(self.ctx)


def _timescale(line: str, rest) -> int:
    """The power of ten of a ``$timescale`` declaration (on one line or over three)."""
    text = line if "$end" in line else line + next(rest) + next(rest)
    m = re.search(r"\$timescale\s*(1|10|100)\s*([munpf]?s)\s*\$end", text)
    if m is None:
        raise ValueError(f"unreadable VCD time scale: {text.strip()!r}")
    return _UNITS[m[2]] + len(m[1]) - 1


def vcd_to_fst(vcd: Path, fst: Path) -> None:
    """Write ``fst`` holding exactly the hierarchy and value changes of ``vcd``."""
    writer = _Writer(fst)
    try:
        with open(vcd) as f:
            for line in f:
                words = line.split()
                if not words:
                    continue
                if words[0] == "$enddefinitions":
                    break
                if words[0] == "$timescale":
                    lib.fstWriterSetTimescale(writer.ctx, _timescale(line, f))
                else:
                    writer.header(words)
            for line in f:
                if line.strip():
                    writer.change(line)
    finally:
        writer.close()


def _convert(vcd: str, fst: str, answer: Connection) -> None:
    try:
        vcd_to_fst(Path(vcd), Path(fst))
    except Exception as e:
        answer.send(f"{e.strerror}" if isinstance(e, OSError) and e.strerror else str(e))
    else:
        answer.send(None)


def convert_in_child(vcd: Path, fst: Path) -> None:
    """:func:`vcd_to_fst` in a child process: the FST library writes through memory maps, and
    a disk that fills under one kills the writer with SIGBUS, which must not end this process.

    Raises
    ------
    OSError
        The conversion failed or its process was killed, saying why.
    """
    receive, send = multiprocessing.Pipe(duplex=False)
    child = multiprocessing.get_context("spawn").Process(target=_convert,
                                                         args=(str(vcd), str(fst), send))
    child.start()
    send.close()
    try:
        message = receive.recv() if receive.poll(None) else None
    except EOFError:
        message = None
    child.join()
    receive.close()
    if child.exitcode and child.exitcode < 0:
        name = signal.Signals(-child.exitcode).name
        hint = " (a full disk?)" if name == "SIGBUS" else ""
        raise OSError(f"the FST writer was killed by {name}{hint}")
    if message is not None or child.exitcode:
        raise OSError(message or f"the FST writer exited with status {child.exitcode}")


def _open(path: Path):
    reader = lib.fstReaderOpen(str(path).encode())
    if reader == ffi.NULL:
        raise OSError(f"{path}: not an FST file")
    return reader


def fst_signals(path: Path) -> dict[str, int]:
    """Every ``scope.name`` an FST file declares, with its width in bits."""
    reader = _open(path)
    try:
        _, signals = get_scopes_signals2(reader)
        return {name: sig.length for name, sig in signals.by_name.items()}
    finally:
        lib.fstReaderClose(reader)


def fst_span(path: Path) -> tuple[int, int]:
    """The first and last time stamps of an FST file, in its time unit."""
    reader = _open(path)
    try:
        return lib.fstReaderGetStartTime(reader), lib.fstReaderGetEndTime(reader)
    finally:
        lib.fstReaderClose(reader)
