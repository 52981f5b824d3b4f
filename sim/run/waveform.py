"""Waveform files of ``k37 run``: the signals a VCD or FST file declares, its time span, and
the GTKWave save file that shows the chips' main signals."""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

from k37.hdl.chipset.map import ALL_AXES
from k37.sim.run.fst import fst_signals, fst_span

__all__ = ["GTKW_GROUPS", "GTKW_WIDTH_PX", "WAVE_FORMATS", "gtkw_flags", "is_fst",
           "wave_signals", "wave_span", "write_gtkw"]

#: The waveform formats ``--vcd`` writes, by file suffix.
WAVE_FORMATS = (".vcd", ".fst")

#: Signals of the GTKWave save file, grouped per chip and axis: (group, names), a name
#: followed by ``:s`` being signed (two's complement). The Z axis's are in the file where the
#: machine has one (a name the VCD does not declare is left out, a group without any too).
#: A name is a signal's last name component, or ``a|b``: the first of the alternatives the
#: file declares, an alternative with a dot naming the end of a dotted path (the K3701's own
#: step outputs, ``k3701.x_pos``, where the chipset's ``step_x_pos`` is not dumped).
GTKW_GROUPS = (
    ("host bus", ("bus__addr", "bus__w_stb", "bus__w_data", "bus__r_stb", "bus__r_data",
                  "irq_interp", "irq_alarm")),
    ("feed", ("fp", "fp_total")),
    ("K3701", tuple(f"step_{a}_{d}|k3701.{a}_{d}" for a in ALL_AXES for d in ("pos", "neg"))),
    *((f"K3702 {a}", (f"{a}__command:s", f"{a}__error:s", f"{a}__dac", f"{a}__alarm_n"))
      for a in ALL_AXES),
    *((f"plant {a}", (f"{a}__count:s",)) for a in ALL_AXES),
)

#: Width in pixels of the wave pane the save file's zoom fits the traced window into.
GTKW_WIDTH_PX = 1000

# GTKWave's trace flags (its analyzer.h: TR_HEX 0x2, TR_DEC 0x4, TR_BIN 0x8, TR_RJUSTIFY
# 0x20, TR_BLANK 0x200, TR_SIGNED 0x400, TR_GRP_BEGIN 0x800000, TR_GRP_END 0x1000000).
_HEX, _DEC, _BIN, _RJUSTIFY, _BLANK, _SIGNED = 0x2, 0x4, 0x8, 0x20, 0x200, 0x400
_GROUP_BEGIN, _GROUP_END = 0x800000 | _BLANK, 0x1000000 | _BLANK
#: Bus-like signals (addresses, data bytes), shown in hex; other numbers in decimal.
_HEX_NAMES = ("bus__addr", "bus__w_data", "bus__r_data")


def gtkw_flags(name: str, width: int, signed: bool) -> int:
    """GTKWave's display flags for a signal: binary for a bit, hex for a bus byte, else
    decimal, signed decimal for a signed number."""
    if width == 1:
        return _RJUSTIFY | _BIN
    if name in _HEX_NAMES:
        return _RJUSTIFY | _HEX
    return _RJUSTIFY | _DEC | (_SIGNED if signed else 0)


def is_fst(path: Path) -> bool:
    """Whether a waveform path names an FST file (by its suffix)."""
    return path.suffix.lower() == ".fst"


def wave_signals(path: Path) -> dict[str, int]:
    """Every ``scope.name`` a VCD or FST file declares, with its width in bits."""
    if is_fst(path):
        return fst_signals(path)
    names: dict[str, int] = {}
    scopes: list[str] = []
    with open(path) as f:
        for line in f:
            words = line.split()
            if not words:
                continue
            if words[0] == "$scope":
                scopes.append(words[2])
            elif words[0] == "$upscope":
                scopes.pop()
            elif words[0] == "$var":
                names[".".join([*scopes, words[4]])] = int(words[2])
            elif words[0] == "$enddefinitions":
                break
    return names


def wave_span(path: Path) -> tuple[int, int]:
    """The first and last time stamps of a VCD or FST file, in its time unit (fs)."""
    if is_fst(path):
        return fst_span(path)
    stamp = re.compile(rb"^#(\d+)\s*$", re.M)
    with open(path, "rb") as f:
        first = next(int(m[1]) for line in f if (m := stamp.match(line)))
        f.seek(max(0, os.fstat(f.fileno()).st_size - 65536))
        last = int(stamp.findall(f.read())[-1])
    return first, last


def _declared(declared: dict[str, int], names: str) -> tuple[str, str] | None:
    """The first of the alternatives ``names`` (``a|b``) the file declares: (the alternative,
    the shortest declared path it names), or None."""
    for name in names.split("|"):
        if "." in name:
            match = [d for d in declared if d.endswith("." + name)]
        else:
            match = [d for d in declared if d.rsplit(".", 1)[-1] == name]
        if match:
            return name.rsplit(".", 1)[-1], min(match, key=len)
    return None


def write_gtkw(wave: Path, path: Path, *, window: tuple[int, int] | None = None,
               width_px: int = GTKW_WIDTH_PX, save_name: str | None = None) -> list[str]:
    """A GTKWave save file for ``wave`` (VCD or FST) showing the chips' main signals, grouped,
    zoomed to fit ``window`` (first and last time, default the file's span) into ``width_px``
    pixels. (Amaranth's VCD writer stamps the values at a window's start at time 0.)

    The waveform is named relative to the save file's folder, and the save file by ``save_name``
    (default: ``path``'s), so GTKWave finds the waveform beside the save file wherever the
    two are moved together (it resolves the dump file against the save file's own place).
    Each listed name is looked up among the signals the file declares (:data:`GTKW_GROUPS`,
    the shortest path winning), so the file names only traced signals; a multi-bit one
    carries the ``[msb:lsb]`` suffix GTKWave gives it. Returns the signals written, as the
    file names them.
    """
    declared = wave_signals(wave)
    start, stop = window or wave_span(wave)
    # GTKWave shows 2**-zoom time units per pixel (its default zoom base, 2).
    zoom = -math.log2(max(stop - start, 1) / width_px)
    relative = Path(os.path.relpath(wave.resolve(), path.resolve().parent)).as_posix()
    lines = [f'[dumpfile] "{relative}"', f'[savefile] "{save_name or path.name}"',
             f"[timestart] {start}", f"*{zoom:.6f} -1"]
    written = []
    for group, names in GTKW_GROUPS:
        found = []
        for entry in names:
            alternatives, _, kind = entry.partition(":")
            chosen = _declared(declared, alternatives)
            if chosen is not None:
                name, sig = chosen
                width = declared[sig]
                shown = sig if width == 1 else f"{sig}[{width - 1}:0]"
                found.append((shown, gtkw_flags(name, width, kind == "s")))
        if not found:
            continue
        lines.append(f"@{_GROUP_BEGIN:x}\n-{group}")
        lines += [f"@{flags:x}\n{shown}" for shown, flags in found]
        lines.append(f"@{_GROUP_END:x}\n-{group}")
        written += [shown for shown, _ in found]
    path.write_text("\n".join(lines) + "\n")
    return written
