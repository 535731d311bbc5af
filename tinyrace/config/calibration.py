"""A perspective camera entry's calibration knobs checked against each other (fov,
intrinsics, distortion, camera_info): what ``PerspectiveCameraConfig.problems`` reports."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from tinyrace.config.sensors import PerspectiveCameraConfig

Found = tuple[str, Any, str]  # (key, value, allowed) of one problem of an entry


def calibration_problems(camera: PerspectiveCameraConfig) -> list[Found]:
    """(key, value, allowed) of each inconsistency of a camera entry's calibration knobs."""
    found: list[Found] = []
    if camera.camera_info is not None:
        for key in ("fov", "intrinsics", "distortion"):
            if getattr(camera, key) is not None:
                allowed = f"give camera_info or {key}, not both (camera_info sets the intrinsics)"
                found.append((key, getattr(camera, key), allowed))
    if camera.intrinsics is not None and camera.fov is not None:
        allowed = "give fov or intrinsics, not both (intrinsics set the field of view)"
        found.append(("fov", camera.fov, allowed))
    if camera.distortion is not None and camera.intrinsics is None and camera.camera_info is None:
        found.append(("distortion", list(camera.distortion), "distortion needs intrinsics"))
    if camera.intrinsics is not None:
        fx, fy = camera.intrinsics[:2]
        if not (fx > 0 and fy > 0 and all(map(math.isfinite, camera.intrinsics))):
            allowed = "expected [fx, fy, cx, cy] with focal lengths fx, fy > 0 [px]"
            found.append(("intrinsics", list(camera.intrinsics), allowed))
    if camera.distortion is not None and not all(map(math.isfinite, camera.distortion)):
        found.append(("distortion", list(camera.distortion), "expected finite numbers"))
    return found
