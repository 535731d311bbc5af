"""CarRacing's bottom bar: speed, wheel spins, steering, gyro and score, in any frame size.

Small frames draw the bar at 4x and area-average it down, as the reference's
smooth scaling of its 1000x800 window does, so that bar lengths keep their
sub-pixel information.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

from tinyrace.cars.state import CarState
from tinyrace.sensors.machinery.drawing import kernel

RGB = tuple[int, int, int]
_WHITE, _BLUE, _PURPLE = (255, 255, 255), (0, 0, 255), (51, 0, 255)
_GREEN, _RED = (0, 255, 0), (255, 0, 0)

# CarRacing's layout: the frame is 40 layout units wide and 40 high; the bar fills the
# bottom BAR_HEIGHT of them. Each instrument sits at a layout column and turns a physical
# value into a bar length in layout units through its gain.
LAYOUT_UNITS = 40  # layout units per frame side
BAR_HEIGHT = 5  # [layout units] the bottom strip
BAR_STEPS = 8  # bar lengths are kept to 1/8 layout unit (times the supersample factor)
SPEED_COLUMN, SPEED_GAIN = 5, 0.02  # [layout units per u/s] true speed, vertical
WHEEL_COLUMNS = (7, 8, 9, 10)  # FL, FR, RL, RR spin, vertical
WHEEL_GAIN = 0.01  # [layout units per rad/s]
STEER_COLUMN, STEER_GAIN = 20, -10.0  # [layout units per rad] front wheel angle, horizontal
GYRO_COLUMN, GYRO_GAIN = 30, -0.8  # [layout units per rad/s] yaw rate, horizontal
# (kind, layout column, colour) of each bar, in the order draw() measures them
_BARS: tuple[tuple[str, int, RGB], ...] = (
    ("v", SPEED_COLUMN, _WHITE),
    ("v", WHEEL_COLUMNS[0], _BLUE),
    ("v", WHEEL_COLUMNS[1], _BLUE),
    ("v", WHEEL_COLUMNS[2], _PURPLE),
    ("v", WHEEL_COLUMNS[3], _PURPLE),
    ("h", STEER_COLUMN, _GREEN),
    ("h", GYRO_COLUMN, _RED),
)
# the same, as arrays for the compiled path (kernels.drawing.draw_bars)
BAR_PLACES = np.array([place for _, place, _ in _BARS])
BARS_VERTICAL = np.array([kind == "v" for kind, _, _ in _BARS])
BAR_COLORS = np.array([color for _, _, color in _BARS])
_LAYER_CACHE_BYTES = 8_000_000  # [bytes] of cached instrument layers per dashboard


# A bar's drawn extent in supersampled pixels: (first, last) output columns of its patch,
# then its box (column start, stop within the patch; row start, stop); () draws nothing
BarBox = tuple[int, ...]
_EMPTY: BarBox = ()


class Dashboard:
    """The instruments of one frame size, drawn into the bottom 5/40 of the frame.

    With ``supersample`` > 1 each bar is drawn at that factor and area-averaged. Bar
    lengths are kept to 1/8 layout unit, then rounded to supersampled pixels to draw; a
    bar's picture depends on that box only, so lengths that round alike share one
    picture and a step whose boxes all stay put redraws nothing. With numba (``drawing``:
    ``TINYRACE_DRAWING``) one compiled call draws the bars of a step instead, into the
    frame: the same pixels.
    """

    def __init__(self, width: int, height: int, supersample: int = 1, drawing: str | None = None):
        self.width, self.height = width, height
        self.top = round(height - BAR_HEIGHT * height / LAYOUT_UNITS)  # first row of the bar
        self.factor = supersample
        self.strip = np.zeros((height - self.top, width, 3), np.uint8)
        # per instrument: value (bar steps, score) -> (picture, layer), the step's one lookup
        self._by_value: list[dict[int, tuple[object, np.ndarray]]] = [
            {} for _ in range(len(_BARS) + 1)
        ]
        self._shown: tuple[int, ...] | None = None  # the values drawn now
        # one layer per instrument (the bars, then the score); the strip is their maximum,
        # so a step redraws only the layers whose picture changed, from layers cached per box
        self._layers = np.zeros((len(_BARS) + 1, *self.strip.shape), np.uint8)
        self._layer_values: list[int | None] = [None] * len(self._layers)  # bar steps, score
        self._layer_pictures: list[object] = [None] * len(self._layers)  # bar boxes, score
        self._cached_layers: dict[tuple[int, object], np.ndarray] = {}
        self._max_cached = max(64, _LAYER_CACHE_BYTES // self.strip.nbytes)
        self.drawing, module = kernel(drawing)  # numba | numpy
        self._draw_bars = None if module is None else module.draw_bars
        self._score: tuple[int, np.ndarray] | None = None  # the compiled path's score layer

    def draw(self, image: np.ndarray, car: CarState, score: float) -> None:
        """The instruments of ``car`` (a car with four wheels) and ``score`` into ``image``."""
        wheels, sign = car.wheels, car.steer_sign
        q = BAR_STEPS * self.factor  # bar steps per layout unit
        shown = (  # bar lengths in steps, in _BARS's order, then the score
            round(SPEED_GAIN * car.speed / car.scale * q),
            round(WHEEL_GAIN * wheels[0].omega * q),
            round(WHEEL_GAIN * wheels[1].omega * q),
            round(WHEEL_GAIN * wheels[2].omega * q),
            round(WHEEL_GAIN * wheels[3].omega * q),
            round(STEER_GAIN * wheels[0].steer * sign * q),
            round(GYRO_GAIN * car.yaw_rate * sign * q),
            int(score),
        )
        if self._draw_bars is not None:
            score_layer = self._score_layer(shown[-1])
            self._draw_bars(image[self.top :], score_layer, shown, self.height, self.factor)
            return
        if shown != self._shown:  # a value moved: its picture may have too
            self._shown = shown
            self._redraw(shown)
        image[self.top :] = self.strip

    def _score_layer(self, score: int) -> np.ndarray:
        """The score's layer (the last one's kept: a score changes a few times a second)."""
        if self._score is None or self._score[0] != score:
            self._score = (score, self._layer(len(_BARS), score))
        return self._score[1]

    def _redraw(self, shown: tuple[int, ...]) -> None:
        """Redraw the layers whose picture changed (a bar's box, the score), then the strip."""
        values, pictures, layers, by_value = (
            self._layer_values,
            self._layer_pictures,
            self._layers,
            self._by_value,
        )
        changed = False
        for index, value in enumerate(shown):
            if values[index] != value:
                values[index] = value
                entry = by_value[index].get(value)
                if entry is None:
                    entry = self._entry(index, value)
                picture, layer = entry
                if pictures[index] != picture:
                    pictures[index] = picture
                    layers[index] = layer
                    changed = True
        if changed:
            np.maximum.reduce(layers, axis=0, out=self.strip)

    def _entry(self, index: int, value: int) -> tuple[object, np.ndarray]:
        """Instrument ``index`` at ``value``: its picture (a bar's box, the score) and layer."""
        entries = self._by_value[index]
        if len(entries) >= self._max_cached:
            entries.clear()
        picture: object = value  # the score
        if index < len(_BARS):
            kind, place, _ = _BARS[index]
            picture = self._bar_box(kind, place, value)
        entry = entries[value] = (picture, self._layer(index, picture))
        return entry

    def _layer(self, index: int, value: object) -> np.ndarray:
        """Instrument ``index`` showing ``value`` (a bar's box, the score), alone in a
        strip-sized picture (cached)."""
        layer = self._cached_layers.get((index, value))
        if layer is None:
            if len(self._cached_layers) >= self._max_cached:
                self._cached_layers.clear()
            layer = np.zeros_like(self.strip)
            if index < len(_BARS):
                assert isinstance(value, tuple)
                self._draw_bar(layer, value, _BARS[index][2])
            else:
                assert isinstance(value, int)
                self._draw_score(layer, value)
            layer.setflags(write=False)
            self._cached_layers[index, value] = layer
        return layer

    def _draw_bar(self, layer: np.ndarray, box: BarBox, color: RGB) -> None:
        if box:
            first, patch = box[0], self._render_bar(box, color)
            region = layer[:, first : first + patch.shape[1]]
            region[:] = patch[:, : region.shape[1]]

    def _draw_score(self, layer: np.ndarray, score: int) -> None:
        mask, x0, y0 = _text_mask(f"{score:04d}", self.width, self.height)
        top = max(y0 - self.top, 0)
        region = layer[top : top + mask.shape[0], x0 : x0 + mask.shape[1]]  # clipped to the bar
        region[:] = mask[: region.shape[0], : region.shape[1], None]

    def _bar_box(self, kind: str, place: int, steps: int) -> BarBox:
        """Where a bar ``steps`` long is drawn at ``factor`` x: (first column, last column,
        column start, column stop, row start, row stop); () when nothing is drawn."""
        if not steps:
            return _EMPTY
        f, value = self.factor, steps / (BAR_STEPS * self.factor)
        s, h = self.width / float(LAYOUT_UNITS) * f, self.height / float(LAYOUT_UNITS) * f
        bottom = (self.height - self.top) * f  # the frame's bottom, in patch rows
        if kind == "v":
            x0, y0, x1, y1 = place * s, bottom - h - h * value, (place + 1) * s, bottom - h
        else:
            x0, y0, x1, y1 = place * s, bottom - 4 * h, (place + value) * s, bottom - 2 * h
        xa, xb = sorted((x0, x1))
        first = max(int(xa // f), 0)
        last = min(int(np.ceil(xb / f)), self.width)
        return (
            first,
            last,
            max(round(xa) - first * f, 0),
            max(round(xb) - first * f, 0),
            max(round(min(y0, y1)), 0),
            max(round(max(y0, y1)), 0),
        )

    def _render_bar(self, box: BarBox, color: RGB) -> np.ndarray:
        """Draw one bar's box at ``factor`` x into a strip-high patch, area-averaged down."""
        f = self.factor
        first, last, col0, col1, row0, row1 = box
        big = np.zeros(((self.height - self.top) * f, max(last - first, 1) * f, 3), np.uint8)
        big[row0:row1, col0:col1] = color
        return cv2.resize(big, (big.shape[1] // f, big.shape[0] // f), interpolation=cv2.INTER_AREA)


@lru_cache(maxsize=512)
def _text_mask(text: str, width: int, height: int) -> tuple[np.ndarray, int, int]:
    """The score rendered once per distinct text and frame size: a grey mask and its corner."""
    sx, sy = width / 1000, height / 800  # the reference lays out text on a 1000x800 window
    scale = 42 * sy / 30  # Hershey simplex is ~30 px tall at scale 1; the reference's font is 42
    thickness = max(1, round(2.5 * sy))
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, thickness)
    mask = np.zeros((th + base + 2, tw + 2), np.uint8)
    cv2.putText(
        mask, text, (1, th + 1), cv2.FONT_HERSHEY_SIMPLEX, scale, 255, thickness, cv2.LINE_AA
    )
    cx, cy = 60 * sx, height - height * 2.5 / 40
    x0 = max(0, min(round(cx - mask.shape[1] / 2), width - mask.shape[1]))  # huge scores: cut
    y0 = max(0, min(round(cy - mask.shape[0] / 2), height - mask.shape[0]))
    mask.setflags(write=False)
    return mask, x0, y0
