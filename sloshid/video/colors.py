"""Named float colours: the BGR colour `synth` paints and the OpenCV HSV range `track` searches for it."""

from __future__ import annotations

from dataclasses import dataclass

from sloshid.core.errors import UserError
from sloshid.core.settings import did_you_mean


@dataclass(frozen=True)
class HsvRange:
    """An OpenCV HSV box (H 0..179, S and V 0..255); a hue low above hue high wraps through 0 (reds)."""

    low: tuple[int, int, int]
    high: tuple[int, int, int]

    def __post_init__(self) -> None:
        for name, triple in (("low", self.low), ("high", self.high)):
            h, s, v = triple
            if not (0 <= h <= 179 and 0 <= s <= 255 and 0 <= v <= 255):
                raise UserError(f"HSV {name} {format_hsv(triple)} is outside H 0..179, S 0..255, V 0..255.")
        if self.low[1] > self.high[1] or self.low[2] > self.high[2]:
            raise UserError(f"HSV low {format_hsv(self.low)} must not exceed high {format_hsv(self.high)} in S and V.")

    @property
    def wraps(self) -> bool:
        """True when the hue range runs through 179 -> 0 (red)."""
        return self.low[0] > self.high[0]

    def describe(self) -> str:
        """Human-readable form used in messages, e.g. 'H 170..10, S 100..255, V 60..255'."""
        return f"H {self.low[0]}..{self.high[0]}, S {self.low[1]}..{self.high[1]}, V {self.low[2]}..{self.high[2]}"


@dataclass(frozen=True)
class ColorPreset:
    """A named float colour: what synth paints (BGR) and the HSV range that finds it."""

    bgr: tuple[int, int, int]
    hsv: HsvRange


PRESETS: dict[str, ColorPreset] = {
    "red": ColorPreset((40, 40, 215), HsvRange((170, 110, 70), (10, 255, 255))),
    "orange": ColorPreset((20, 130, 245), HsvRange((8, 120, 90), (22, 255, 255))),
    "yellow": ColorPreset((30, 215, 235), HsvRange((22, 110, 90), (35, 255, 255))),
    "green": ColorPreset((60, 190, 40), HsvRange((45, 110, 60), (80, 255, 255))),
    "blue": ColorPreset((215, 80, 30), HsvRange((100, 140, 60), (125, 255, 255))),
    "magenta": ColorPreset((200, 40, 205), HsvRange((140, 110, 60), (172, 255, 255))),
    "dark": ColorPreset((22, 26, 34), HsvRange((0, 0, 0), (179, 255, 60))),
}
"""Float and dye colour presets; the HSV ranges are wide enough for sensor noise, blur and compression. "dark" is any
hue too dark to have one: a near-black liquid (cola, coffee, ink), which no hue range finds."""

DEFAULT_FLOAT_COLOR = "red"
"""The colour synth paints by default and track looks for by default."""


def preset(name: str) -> ColorPreset:
    """The preset called `name`, or a UserError listing the choices."""
    try:
        return PRESETS[name]
    except KeyError:
        raise UserError(
            f"unknown colour '{name}'{did_you_mean(name, PRESETS)}; choose one of {', '.join(PRESETS)}."
        ) from None


def format_hsv(triple: tuple[int, int, int]) -> str:
    """'H,S,V' as written on the command line."""
    return ",".join(str(v) for v in triple)
