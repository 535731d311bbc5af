"""A frame of the shipped ``sensors`` experiment's video, for the README.

Runs ``tinyrace run sensors`` (Formula Student track, six sensors, ``view: sensors``) in a
temporary folder and saves frame ``FRAME`` of its episode video as ``sensors_frame.png``
next to this file: on the left a map around the car with the lidar's rays, the detected
cones and the lookahead points; on the right the perspective camera's RGB view above its
``classes`` view.

Run from the repository root: ``python docs/make_sensors_frame.py``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import cv2

HERE = Path(__file__).resolve().parent
FRAME = 120  # the reset frame is 0, then one frame per step


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        command = [sys.executable, "-m", "tinyrace", "run", "sensors", "--quiet", "--out", tmp]
        subprocess.run(command, check=True)
        (video,) = Path(tmp).rglob("episode_000.mp4")
        capture = cv2.VideoCapture(str(video))
        capture.set(cv2.CAP_PROP_POS_FRAMES, FRAME)
        ok, frame = capture.read()
        capture.release()
        if not ok:
            raise SystemExit(f"{video}: no frame {FRAME}")
    cv2.imwrite(str(HERE / "sensors_frame.png"), frame)
    print(f"wrote {HERE / 'sensors_frame.png'} ({frame.shape[1]}x{frame.shape[0]})")


if __name__ == "__main__":
    main()
