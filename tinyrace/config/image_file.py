"""Reading track images the user drew, with bounds: the size is read from the header first.

PNG, JPEG and binary PGM/PPM (``P5``/``P6``, as ROS maps use) are read. The width and height
come from the file's header; an image of more than ``max_pixels`` is refused before it is
decoded, and so are a corrupt or truncated file, an unknown format and a JPEG with four
channels (CMYK). Every refusal is a ConfigError naming the file.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from tinyrace.config.yaml_file import read_bytes
from tinyrace.errors import ConfigError, Problem

DEFAULT_MAX_IMAGE_PIXELS = 36_000_000  # [px] width * height, 6000 x 6000: loads in about 2 s
MAX_IMAGE_BYTES = 1 << 30  # [bytes] an image file (1 GiB); the pixel cap usually binds first

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_END = b"\x00\x00\x00\x00IEND\xaeB`\x82"
_PNG_COLOR_TYPES = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}  # colour type -> channels
_JPEG_SOF = {0xC0 + n for n in range(16)} - {0xC4, 0xC8, 0xCC}  # start-of-frame markers


@dataclass(frozen=True)
class ImageHeader:
    """What an image file's header says."""

    format: str  # "PNG", "JPEG" or "PNM"
    width: int  # [px]
    height: int  # [px]
    channels: int
    maxval: int = 255  # a PGM/PPM's white (its samples run from 0 to it)


class _Bad(Exception):
    """The file is not a well-formed image; the message says why."""


def read_header(data: bytes) -> ImageHeader:
    """The format, size and channels from an image file's bytes; raises _Bad when malformed."""
    if data.startswith(_PNG_SIGNATURE):
        return _png_header(data)
    if data.startswith(b"\xff\xd8"):
        return _jpeg_header(data)
    if data[:2] in (b"P5", b"P6"):
        return _pnm_header(data)
    raise _Bad("not a PNG, JPEG or binary PGM/PPM file")


def _png_header(data: bytes) -> ImageHeader:
    if len(data) < 33 or data[12:16] != b"IHDR":
        raise _Bad("a PNG without its IHDR header (corrupt or truncated)")
    width, height, depth, color_type = struct.unpack(">IIBB", data[16:26])
    if color_type not in _PNG_COLOR_TYPES or depth not in (1, 2, 4, 8, 16):
        raise _Bad(f"a PNG of an unknown kind (colour type {color_type}, bit depth {depth})")
    if not data.endswith(_PNG_END):
        raise _Bad("a PNG that does not end with its IEND chunk (truncated)")
    return ImageHeader("PNG", width, height, _PNG_COLOR_TYPES[color_type])


def _jpeg_header(data: bytes) -> ImageHeader:
    at = 2
    while at + 4 <= len(data):
        if data[at] != 0xFF:
            raise _Bad(f"a JPEG with a broken segment at byte {at} (corrupt)")
        marker = data[at + 1]
        if marker == 0xFF:  # fill byte
            at += 1
            continue
        (length,) = struct.unpack(">H", data[at + 2 : at + 4])
        if marker in _JPEG_SOF:
            if at + 10 > len(data):
                break
            height, width, channels = struct.unpack(">HHB", data[at + 5 : at + 10])
            if data.rfind(b"\xff\xd9") < at:  # no end-of-image marker after the frame header
                raise _Bad("a JPEG that does not end with its end-of-image marker (truncated)")
            return ImageHeader("JPEG", width, height, channels)
        if length < 2:
            raise _Bad(f"a JPEG with a broken segment at byte {at} (corrupt)")
        at += 2 + length
    raise _Bad("a JPEG without its frame header (corrupt or truncated)")


def _pnm_header(data: bytes) -> ImageHeader:
    width, height, maxval, start = _pnm_fields(data)
    channels = 1 if data[:2] == b"P5" else 3
    if not 0 < maxval < 65536:
        raise _Bad(f"a PGM/PPM with maxval {maxval} (expected 1 to 65535)")
    needed = width * height * channels * (1 if maxval < 256 else 2)
    if len(data) - start < needed:
        raise _Bad("a PGM/PPM shorter than its header says (truncated)")
    return ImageHeader("PNM", width, height, channels, maxval)


_PNM_HEADER_BYTES = 4096  # [bytes] the magic, width, height, maxval and comments among them


def _pnm_fields(data: bytes) -> tuple[int, int, int, int]:
    """Width, height, maxval and where the pixels start; ``#`` comments (map_saver's
    ``# CREATOR: ...`` line) may stand between any two header fields."""
    fields: list[int] = []
    at = 2
    while len(fields) < 3:
        while at < len(data) and data[at : at + 1].isspace():
            at += 1
        if data[at : at + 1] == b"#":  # a comment runs to the end of its line
            end = data.find(b"\n", at, _PNM_HEADER_BYTES)
            if end < 0:
                raise _Bad("a PGM/PPM with a broken header (corrupt)")
            at = end + 1
            continue
        end = at
        while end < len(data) and data[end : end + 1].isdigit() and end - at < 10:
            end += 1
        if end == at or at >= _PNM_HEADER_BYTES:
            raise _Bad("a PGM/PPM with a broken header (corrupt)")
        fields.append(int(data[at:end]))
        at = end
    if not data[at : at + 1].isspace():
        raise _Bad("a PGM/PPM with a broken header (corrupt)")
    return fields[0], fields[1], fields[2], at + 1


def check_size(header: ImageHeader, max_pixels: int) -> str | None:
    """Why an image of this header is refused (too large, empty, wrong channels), or None."""
    pixels = header.width * header.height
    if pixels == 0:
        return f"an image of {header.width} x {header.height} px has no pixels"
    if pixels > max_pixels:
        return (
            f"an image of {header.width} x {header.height} = {pixels:,} px is above the cap of "
            f"{max_pixels:,} px (files.max_image_pixels)"
        )
    if header.format == "JPEG" and header.channels not in (1, 3):
        return f"a JPEG of {header.channels} channels (CMYK?): save it as RGB or grey"
    return None


def read_image_bgr(
    path: Path, max_pixels: int, source: str, where: str, value: str | None = None
) -> np.ndarray:
    """The image at ``path`` as (H, W, 3) uint8 BGR (grey and alpha converted, alpha dropped).

    ``source``, ``where`` and ``value`` (file, key path and value of the setting that named
    the image) locate the ConfigError raised for a file that is missing, malformed or too large.
    """

    def refuse(reason: str) -> ConfigError:
        allowed = f"expected a track image (PNG or JPEG, or a binary PGM/PPM): {reason}"
        return ConfigError(Problem(source, where, value or str(path), allowed))

    try:
        data = read_bytes(path, MAX_IMAGE_BYTES, "an image file")
    except ConfigError as exc:
        raise refuse(f"{path}: {exc.problems[0].allowed.removeprefix('expected ')}") from None
    try:
        header = read_header(data)
    except (_Bad, struct.error) as exc:
        raise refuse(f"{path.name} is {exc}" if isinstance(exc, _Bad) else "corrupt") from None
    reason = check_size(header, max_pixels)
    if reason is not None:
        raise refuse(f"{path.name} is {reason}")
    if header.format == "PNM" and header.maxval not in (255, 65535):
        bgr = _scaled_pnm(data, header.maxval)  # OpenCV reads the samples unscaled
    else:
        bgr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    del data
    if bgr is None or bgr.shape[:2] != (header.height, header.width):
        raise refuse(f"{path.name} cannot be decoded (corrupt)")
    return bgr


def _scaled_pnm(data: bytes, maxval: int) -> np.ndarray | None:
    """A PGM/PPM whose white is ``maxval`` (not 255 or 65535) as 8-bit BGR, its samples
    scaled to 0-255 as every reader of the format does (a map_saver PGM of maxval 100 is
    white at 100); a sample above maxval counts as white."""
    raw = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if raw is None:
        return None
    scaled = np.rint(np.minimum(raw, maxval) * (255.0 / maxval)).astype(np.uint8)
    return cv2.cvtColor(scaled, cv2.COLOR_GRAY2BGR) if scaled.ndim == 2 else scaled
