"""Episode videos that play everywhere: H.264 mp4 (yuv420p, faststart) through imageio-ffmpeg's
bundled ffmpeg, or VP9 WebM through OpenCV where imageio-ffmpeg is missing.

yuv420p halves the colour resolution, so both sides of a frame must be even: odd frames get
one more row or column (a copy of the last), never lose one.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

import numpy as np

H264_SUFFIX = ".mp4"
VP9_SUFFIX = ".webm"


class VideoWriter(Protocol):
    """Takes RGB frames of one size, in order; ``close`` finishes a playable file."""

    path: Path

    def write(self, frame: np.ndarray) -> None: ...

    def close(self) -> None: ...


def even_frame(frame: np.ndarray) -> np.ndarray:
    """``frame`` (H x W x 3 RGB) padded by edge copies to even height and width."""
    pad_h, pad_w = frame.shape[0] % 2, frame.shape[1] % 2
    if not (pad_h or pad_w):
        return np.ascontiguousarray(frame)
    return np.pad(frame, ((0, pad_h), (0, pad_w), (0, 0)), mode="edge")


def h264_available() -> bool:
    """Whether imageio-ffmpeg (with its bundled ffmpeg and libx264) can be used."""
    try:
        import imageio_ffmpeg

        imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):
        return False
    return True


def open_video(stem: Path, fps: float) -> VideoWriter:
    """A writer for ``stem`` + .mp4 (H.264) or, without imageio-ffmpeg, + .webm (VP9)."""
    if h264_available():
        return H264Writer(stem.with_suffix(H264_SUFFIX), fps)
    return Vp9Writer(stem.with_suffix(VP9_SUFFIX), fps)


class H264Writer:
    """H.264 in mp4 through a piped ffmpeg process (started at the first frame)."""

    def __init__(self, path: Path, fps: float):
        self.path = path
        self.fps = fps  # [Hz]
        self._pipe: Any = None  # imageio-ffmpeg's generator
        self._size: tuple[int, int] | None = None  # (w, h), even

    def write(self, frame: np.ndarray) -> None:
        frame = even_frame(frame)
        if self._pipe is None:
            self._start((frame.shape[1], frame.shape[0]))
        self._pipe.send(frame)

    def _start(self, size: tuple[int, int]) -> None:
        import imageio_ffmpeg

        self._size = size
        self._pipe = imageio_ffmpeg.write_frames(
            str(self.path),
            size,
            fps=self.fps,
            codec="libx264",
            pix_fmt_in="rgb24",
            pix_fmt_out="yuv420p",
            macro_block_size=1,  # the frame is even already; ffmpeg must not resize it
            quality=None,
            ffmpeg_log_level="error",
            output_params=["-crf", "20", "-preset", "veryfast", "-movflags", "+faststart"],
        )
        self._pipe.send(None)  # runs the generator up to its first frame

    def close(self) -> None:
        if self._pipe is not None:
            self._pipe.close()  # ffmpeg writes the trailer and moves the index to the front
            self._pipe = None


class Vp9Writer:
    """VP9 in WebM through OpenCV's ffmpeg (its wheels cannot write H.264)."""

    def __init__(self, path: Path, fps: float):
        self.path = path
        self.fps = fps  # [Hz]
        self._writer: Any = None  # cv2.VideoWriter

    def write(self, frame: np.ndarray) -> None:
        import cv2

        frame = even_frame(frame)
        if self._writer is None:
            size = (frame.shape[1], frame.shape[0])
            fourcc = cv2.VideoWriter.fourcc(*"VP90")
            self._writer = cv2.VideoWriter(str(self.path), fourcc, self.fps, size)
        self._writer.write(np.ascontiguousarray(frame[..., ::-1]))  # OpenCV takes BGR

    def close(self) -> None:
        if self._writer is not None:
            self._writer.release()
            self._writer = None
