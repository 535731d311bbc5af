"""Issue 12.3, images: the size is read from the header and checked against a configurable
pixel cap before decoding; corrupt, truncated, wrong-channel and non-image files get a
ConfigError naming the file; derived buffers (planes, overviews, cameras) are capped."""

from __future__ import annotations

import os
import struct
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from tinyrace.config import load_env_config
from tinyrace.config.image_file import DEFAULT_MAX_IMAGE_PIXELS, read_header
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError

CAMERA = {"id": "front", "resolution": [12, 16], "roi": [24, 32]}


def _folder(tmp_path: Path, image: str = "track.png", **extra) -> Path:
    config = {"cameras": [CAMERA], "tracks": [{"image": image, "spawns": [[20, 20, 0]]}], **extra}
    (tmp_path / "track.yaml").write_text(yaml.safe_dump(config))
    return tmp_path


def _png(width: int = 64, height: int = 64, channels: int = 3, dtype=np.uint8) -> bytes:
    shape = (height, width) if channels == 1 else (height, width, channels)
    image = np.zeros(shape, dtype)
    image[10:30, 10:30] = np.iinfo(dtype).max
    ok, data = cv2.imencode(".png", image)
    assert ok
    return data.tobytes()


def _jpeg() -> bytes:
    ok, data = cv2.imencode(".jpg", np.full((64, 64, 3), 255, np.uint8))
    assert ok
    return data.tobytes()


def _with_png_size(data: bytes, width: int, height: int) -> bytes:
    return data[:16] + struct.pack(">II", width, height) + data[24:]


def _problem(folder: Path) -> str:
    with pytest.raises(ConfigError) as caught:
        TinyRaceEnv(environment=folder)
    (problem,) = caught.value.problems
    assert problem.source == str(folder / "track.yaml") and problem.path == "tracks[0].image"
    return str(problem)


@pytest.mark.parametrize("side", [100_000, 2**32 - 1])
def test_a_huge_header_is_refused_before_decoding(tmp_path: Path, side: int):
    (tmp_path / "track.png").write_bytes(_with_png_size(_png(), side, side))
    assert "above the cap" in _problem(_folder(tmp_path))


def test_the_pixel_cap_is_a_config_key(tmp_path: Path):
    (tmp_path / "track.png").write_bytes(_png(64, 64))
    folder = _folder(tmp_path, files={"max_image_pixels": 64 * 64 - 1})
    assert "files.max_image_pixels" in _problem(folder)
    _folder(tmp_path, files={"max_image_pixels": 64 * 64})
    TinyRaceEnv(environment=folder).reset(seed=0)


@pytest.mark.parametrize(
    "name, damage, reason",
    [
        ("track.png", lambda b: b[: len(b) // 2], "truncated"),
        ("track.png", lambda b: b[:20], "corrupt or truncated"),
        ("track.png", lambda b: _with_png_size(b, 0, 64), "no pixels"),
        ("track.png", lambda b: b[:25] + b"\x07" + b[26:], "unknown kind"),
        ("track.jpg", lambda b: b[: len(b) - 40], "truncated"),
        ("track.jpg", lambda b: b[:2] + b"\x00" * 40, "corrupt"),
        ("track.png", lambda b: b"name,x,y\n1,2,3\n", "not a PNG"),
        ("track.png", lambda b: b"", "not a PNG"),
    ],
)
def test_a_damaged_image_names_the_file(tmp_path: Path, name: str, damage, reason: str):
    good = _jpeg() if name.endswith(".jpg") else _png()
    (tmp_path / name).write_bytes(damage(good))
    text = _problem(_folder(tmp_path, name))
    assert reason in text and name in text


def test_a_cmyk_jpeg_is_refused(tmp_path: Path):
    data = bytearray(_jpeg())
    sof = data.find(b"\xff\xc0")
    assert data[sof + 9] == 3  # components
    data[sof + 9] = 4
    (tmp_path / "track.jpg").write_bytes(bytes(data))
    assert "4 channels" in _problem(_folder(tmp_path, "track.jpg"))


def test_an_image_fifo_is_refused_without_blocking(tmp_path: Path):
    os.mkfifo(tmp_path / "track.png")
    assert "a FIFO" in _problem(_folder(tmp_path))


@pytest.mark.parametrize(
    "channels, dtype", [(1, np.uint8), (3, np.uint8), (4, np.uint8), (3, np.uint16)]
)
def test_grey_rgb_rgba_and_16_bit_pngs_load_alike(tmp_path: Path, channels: int, dtype):
    (tmp_path / "track.png").write_bytes(_png(channels=channels, dtype=dtype))
    env = TinyRaceEnv(environment=_folder(tmp_path), render_mode="rgb_array")
    env.reset(seed=0)
    white = env.track_source.tracks[0].picture[15, 15, :3]
    assert white.tolist() == [255, 255, 255]


def test_a_pgm_loads(tmp_path: Path):
    pixels = np.zeros((40, 50), np.uint8)
    pixels[5:10] = 255
    (tmp_path / "track.pgm").write_bytes(b"P5\n50 40\n255\n" + pixels.tobytes())
    header = read_header((tmp_path / "track.pgm").read_bytes())
    assert (header.width, header.height, header.channels) == (50, 40, 1)
    env = TinyRaceEnv(environment=_folder(tmp_path, "track.pgm"))
    env.reset(seed=0)


def test_a_black_plane_is_capped_too(tmp_path: Path):
    config = {"cameras": [CAMERA], "tracks": [{"plane_size": [20000, 20000]}]}
    with pytest.raises(ConfigError, match=r"plane_size.*max_image_pixels"):
        load_env_config(config)  # checked when the config is read
    assert DEFAULT_MAX_IMAGE_PIXELS < 20000 * 20000


def test_cameras_together_are_capped():
    cameras = [{"id": f"c{i}", "resolution": [4096, 4096]} for i in range(2)]
    with pytest.raises(ConfigError, match="cameras"):
        load_env_config({"cameras": cameras})


def test_the_overview_is_capped_whatever_the_downscale(tmp_path: Path):
    from tinyrace.config.schema import MAX_FRAME_PIXELS

    (tmp_path / "track.png").write_bytes(_png(400, 300))
    folder = _folder(tmp_path, sim={"overview_downscale": 0.05})  # 8000 x 6000 asked for
    env = TinyRaceEnv(environment=folder, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape[0] * frame.shape[1] <= MAX_FRAME_PIXELS
    assert frame.shape[1] > 400  # still enlarged as far as the cap allows
