"""What a host bridge in front of a chipset tells of it (:attr:`k37.hdl.bridge.protocol.Op.IDENT`),
from the chipset's build parameters, without Amaranth.

Two chipsets have the same identity when they have the same axes, register maps and accel/decel
circuits: what the firmware of a job needs to find. The board's bitstream and a host's job
compute it with :func:`chipset_identity` from the arguments of
:class:`k37.hdl.chipset.chip.Chipset`.
"""

from __future__ import annotations

import enum
import json
from collections.abc import Iterable, Mapping

from k37.hdl.bridge.protocol import Identity, map_fingerprint
from k37.hdl.chipset.map import axis_names, chip_selects
from k37.hdl.feed.map.feed_rate import feed_map

__all__ = ["chipset_identity"]


def _name(value: object) -> object:
    return value.value if isinstance(value, enum.Enum) else value


def chipset_identity(*, axes: int = 2, accel: object = "pre", accel_bits: int = 15,
                     accel_shape: object = "exponential",
                     axis_accel: Mapping[str, tuple[object, int]] | None = None,
                     axis_fa: Iterable[str] = ()) -> Identity:
    """The identity of ``Chipset(axes=..., accel=..., ...)`` (its arguments, same defaults)."""
    names = axis_names(axes)
    fa = tuple(axis for axis in names if axis in set(axis_fa))
    chips = dict(chip_selects(axes))
    if fa:
        chips["FEED"] = (chips["FEED"][0], feed_map(fa))
    accel, shape = _name(accel), _name(accel_shape)
    own = {axis: (_name(s), bits) for axis, (s, bits) in (axis_accel or {}).items()}
    circuits = ({"accel": (shape, accel_bits)} if accel == "pre" else
                {f"accel_{axis}": own.get(axis, (shape, accel_bits)) for axis in names}
                if accel == "post" else {})
    build = json.dumps({"accel": accel, "circuits": circuits, "axis_fa": fa}, sort_keys=True)
    return Identity(axes, map_fingerprint(
        [(name, select, regmap) for name, (select, regmap) in chips.items()], build))
