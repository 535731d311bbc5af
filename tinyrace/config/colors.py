"""Colours as written in YAML: ``[b, g, r]`` lists (tinycarlo's order) or ``"#rrggbb"``.

Internally every colour is held in RGB order, the order of tinyrace's observations.
"""

from __future__ import annotations

import re

_HEX = re.compile(r"^#([0-9a-fA-F]{6})$")


class Color(tuple[int, int, int]):
    """An RGB colour, 0-255 per channel. Build it with ``Color.from_yaml`` or ``Color.rgb``."""

    __slots__ = ()

    @classmethod
    def rgb(cls, r: int, g: int, b: int) -> Color:
        return cls((int(r), int(g), int(b)))

    @classmethod
    def from_yaml(cls, value: object, *, binary: bool = False) -> Color:
        """Parse a YAML value; raise ValueError with what is allowed.

        ``binary`` demands channels of 0 or 255 (tinycarlo's rule for colours that
        name pixel classes on a binarised track image).
        """
        if isinstance(value, str):
            match = _HEX.match(value.strip())
            if not match:
                raise ValueError('expected a "#rrggbb" string (RGB) or a [b, g, r] list')
            digits = match.group(1)
            channels = [int(digits[i : i + 2], 16) for i in (0, 2, 4)]
        elif isinstance(value, (list, tuple)) and len(value) == 3:
            if not all(isinstance(c, int) and not isinstance(c, bool) for c in value):
                raise ValueError("expected three whole numbers in [b, g, r] order")
            channels = [value[2], value[1], value[0]]
        else:
            raise ValueError('expected a [b, g, r] list (BGR, as tinycarlo) or a "#rrggbb" string')
        if not all(0 <= c <= 255 for c in channels):
            raise ValueError("expected channels from 0 to 255")
        if binary and not all(c in (0, 255) for c in channels):
            raise ValueError("expected every channel to be 0 or 255 (the track image is binarised)")
        return cls.rgb(*channels)

    @property
    def bgr(self) -> tuple[int, int, int]:
        return (self[2], self[1], self[0])

    def __repr__(self) -> str:
        return "#{:02x}{:02x}{:02x}".format(*self)


# The cars of a race, in order: car 0 keeps CarRacing's red; the others are told apart
# at a glance (Okabe-Ito's colour-blind-safe palette, then greys).
CAR_PALETTE: tuple[Color, ...] = (
    Color.rgb(204, 0, 0),
    Color.rgb(0, 114, 178),
    Color.rgb(230, 159, 0),
    Color.rgb(0, 158, 115),
    Color.rgb(204, 121, 167),
    Color.rgb(86, 180, 233),
    Color.rgb(240, 228, 66),
    Color.rgb(213, 94, 0),
)


def palette_color(car: int) -> Color:
    """Car ``car``'s colour when its config names none (the palette, repeated)."""
    return CAR_PALETTE[car % len(CAR_PALETTE)]
