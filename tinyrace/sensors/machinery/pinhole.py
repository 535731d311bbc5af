"""Pinhole camera core: the flat ground seen through a perspective camera on the car.

The ground is the plane z = 0. A pinhole camera at ``position`` = (ahead, right, height)
from the car's reference point, turned by yaw (+ right), pitch (+ down) and roll (+ clockwise
as the camera sees it), maps ground points to pixels by one homography; the image is the
ground texture pushed through it by one ``cv2.warpPerspective``. Pixels whose ray misses the
ground (above the horizon) or meets it beyond ``max_range`` get the sky colour, from a mask
that depends on the camera alone and is computed once. The whole rows of sky at the top
(above the horizon of a level camera) are filled in one slice and never warped: only the
rows below them are (``warp_below_sky``).

Pixels: u right, v down, a pixel's centre on integer coordinates; the principal point is the
image centre and the focal length follows from the horizontal field of view, unless the
camera has its own ``matrix`` (fx, fy, cx, cy) [px]. With plumb_bob ``distortion`` (k1, k2,
p1, p2, k3: OpenCV's model, as ``cv2.projectPoints``), no homography maps the ground to the
image: each pixel's ray is undistorted once (``cv2.undistortPoints``, iterated to 1e-12)
into the ground point it sees in the car frame, and every image is one ``cv2.remap`` of the
texture at those points moved by the car's pose (``remap_below_sky``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np


@dataclass(frozen=True)
class Pinhole:
    """A camera's intrinsics and its pose on the car."""

    size: tuple[int, int]  # (width, height) [px]
    hfov: float  # [rad] horizontal field of view
    position: tuple[float, float, float]  # [track units] ahead, right, height
    yaw: float = 0.0  # [rad] + turns the camera to the right
    pitch: float = 0.0  # [rad] + tilts it down toward the ground
    roll: float = 0.0  # [rad] + turns it clockwise about its optical axis
    max_range: float | None = None  # [track units] ground beyond this is sky; None: no limit
    matrix: tuple[float, float, float, float] | None = None  # [px] fx, fy, cx, cy; None: hfov's
    distortion: tuple[float, ...] | None = None  # plumb_bob k1, k2, p1, p2, k3; None: none

    @cached_property
    def intrinsics(self) -> np.ndarray:
        """K (3x3): ``matrix``, or the focal length [px] from the fov, principal point at the
        image centre."""
        if self.matrix is not None:
            fx, fy, cx, cy = self.matrix
            return np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])
        width, height = self.size
        focal = (width / 2) / math.tan(self.hfov / 2)
        return np.array([[focal, 0, (width - 1) / 2], [0, focal, (height - 1) / 2], [0, 0, 1]])

    @property
    def distorted(self) -> bool:
        """Whether the lens distorts (any nonzero plumb_bob coefficient)."""
        return self.distortion is not None and any(self.distortion)

    def _rays(self) -> np.ndarray:
        """(H, W, 3) each pixel's ray in the car frame (ahead, right, up), not normalised."""
        width, height = self.size
        u, v = np.meshgrid(np.arange(width), np.arange(height))
        if not self.distorted:
            pixels = np.stack([u, v, np.ones_like(u)], axis=-1).astype(np.float64)
            rays: np.ndarray = pixels @ np.linalg.inv(self.intrinsics).T @ self.axes
            return rays
        points = np.stack([u, v], axis=-1).reshape(-1, 1, 2).astype(np.float64)
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
        ideal = cv2.undistortPoints(
            points,
            self.intrinsics,
            np.asarray(self.distortion, np.float64),
            R=None,
            P=None,
            criteria=criteria,
        ).reshape(height, width, 2)
        normal = np.concatenate([ideal, np.ones((height, width, 1))], axis=-1)
        turned: np.ndarray = normal @ self.axes
        return turned

    @cached_property
    def ground_points(self) -> np.ndarray:
        """(2, H, W) float32 [track units] the ground point (ahead, right) in the car frame
        each pixel's ray meets (0 where it meets none: sky)."""
        rays = self._rays()
        down = -rays[..., 2]
        reach = np.where(down > 1e-12, self.position[2] / np.where(down > 1e-12, down, 1), 0)
        ahead = self.position[0] + reach * rays[..., 0]
        right = self.position[1] + reach * rays[..., 1]
        return np.stack([ahead, right]).astype(np.float32)

    @cached_property
    def axes(self) -> np.ndarray:
        """(3, 3) rows: the camera's right, down and optical axes in the car frame
        (ahead, right, up)."""
        cy, sy = math.cos(self.yaw), math.sin(self.yaw)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        optical = np.array([cp * cy, cp * sy, -sp])
        right = np.array([-sy, cy, 0.0])
        down = np.array([-sp * cy, -sp * sy, -cp])
        cr, sr = math.cos(self.roll), math.sin(self.roll)
        return np.stack([cr * right + sr * down, -sr * right + cr * down, optical])

    @cached_property
    def ground_to_image(self) -> np.ndarray:
        """H (3x3): ground point (ahead, right, 1) in the car frame -> homogeneous pixel."""
        axes = self.axes
        camera = np.asarray(self.position, np.float64)
        extrinsic = np.column_stack([axes[:, 0], axes[:, 1], -axes @ camera])
        homography: np.ndarray = self.intrinsics @ extrinsic
        return homography

    @cached_property
    def image_to_ground(self) -> np.ndarray:
        """The inverse of ``ground_to_image``."""
        return np.linalg.inv(self.ground_to_image)

    def project(self, points: np.ndarray) -> np.ndarray:
        """(N, 2) pixels of (N, 3) car-frame points (ahead, right, up); in front of the camera."""
        relative = np.asarray(points, np.float64) - np.asarray(self.position)
        camera = relative @ self.axes.T  # (N, 3): x right, y down, z along the optical axis
        pixels = camera @ self.intrinsics.T
        projected: np.ndarray = pixels[:, :2] / pixels[:, 2:3]
        return projected

    @cached_property
    def sky(self) -> np.ndarray:
        """(H, W) bool: pixels whose ray misses the ground or meets it beyond max_range."""
        rays = self._rays()  # car frame
        down = -rays[..., 2]
        missed: np.ndarray = down <= 1e-12
        reach = self.position[2] / np.where(missed, 1.0, down)  # ray length to the ground
        far = np.hypot(rays[..., 0], rays[..., 1]) * reach  # [track units] along the ground
        if self.max_range is not None:
            missed |= far > self.max_range
        return missed

    @cached_property
    def sky_rows(self) -> int:
        """How many whole rows at the top of the image are sky."""
        full = np.asarray(self.sky.all(axis=1))
        return int(np.argmin(full)) if not full.all() else len(full)

    @cached_property
    def below_sky_to_ground(self) -> np.ndarray:
        """H (3x3): pixel (u, v) of the image below the whole rows of sky, v counted from the
        first row below them -> ground point (ahead, right, 1) in the car frame."""
        shift = np.array([[1.0, 0, 0], [0, 1.0, self.sky_rows], [0, 0, 1.0]])
        below: np.ndarray = self.image_to_ground @ shift
        return below

    def sky_paint(self, value: tuple[int, ...], channels: tuple[int, ...] = ()) -> SkyPaint:
        """The sky of this camera's images with ``channels`` (() for one) set to ``value`` (one
        number per channel), made once per value."""
        key = (value, channels)
        paint = self._sky_paints.get(key)
        if paint is None:
            paint = self._sky_paints[key] = SkyPaint.make(self, value, channels)
        return paint

    @cached_property
    def _sky_paints(self) -> dict[tuple[tuple[int, ...], tuple[int, ...]], SkyPaint]:
        return {}


@dataclass(frozen=True, eq=False)
class SkyPaint:
    """A camera's sky in one pixel format (uint8), made once: the whole rows at the top are
    one slice copy; the sky below them (a rolled horizon, ground beyond max_range) one masked
    copy. (Broadcasting a colour into an image costs numpy about 2 ns per byte: as much as
    the warp.)"""

    rows: np.ndarray  # (rows, W, *channels) sky
    # below the rows: (H - rows, W, *channels) sky and its (H - rows, W) uint8 mask, nonzero
    # where the sky is; None when no pixel below the rows is sky
    below: tuple[np.ndarray, np.ndarray] | None

    @classmethod
    def make(cls, camera: Pinhole, value: tuple[int, ...], channels: tuple[int, ...]) -> SkyPaint:
        """The sky of ``camera`` with ``channels`` set to ``value``."""
        width, height = camera.size
        rows = camera.sky_rows
        sky = np.empty((height, width, *channels), np.uint8)
        sky[...] = np.asarray(value, np.uint8).reshape(channels) if channels else value[0]
        below_mask = camera.sky[rows:]
        below = (sky[rows:].copy(), below_mask.astype(np.uint8)) if below_mask.any() else None
        return cls(sky[:rows].copy(), below)

    def paint(self, image: np.ndarray) -> None:
        """Set the sky pixels of ``image`` (H, W, *channels)."""
        rows = len(self.rows)
        image[:rows] = self.rows
        if self.below is not None:
            sky, mask = self.below
            below = image[rows:]
            done = cv2.copyTo(sky, mask, below)
            assert done is below, "cv2 wrote into its own array"


def world_to_car(front: tuple[float, float], heading: float, y_down: bool) -> np.ndarray:
    """(3x3) track point -> car frame (ahead, right) for a car at ``front`` with ``heading``
    (counter-clockwise on y-up tracks, clockwise on y-down image tracks)."""
    fx, fy = math.cos(heading), math.sin(heading)
    rx, ry = (-fy, fx) if y_down else (fy, -fx)
    x, y = front
    return np.array([[fx, fy, -(x * fx + y * fy)], [rx, ry, -(x * rx + y * ry)], [0, 0, 1]])


def car_to_world(front: tuple[float, float], heading: float, y_down: bool) -> np.ndarray:
    """(3x3) car frame (ahead, right) -> track point: the inverse of ``world_to_car``."""
    fx, fy = math.cos(heading), math.sin(heading)
    rx, ry = (-fy, fx) if y_down else (fy, -fx)
    return np.array([[fx, rx, front[0]], [fy, ry, front[1]], [0, 0, 1]])


def warp_below_sky(
    camera: Pinhole,
    ground: np.ndarray,
    world_to_ground: np.ndarray,
    placed: np.ndarray,
    interpolation: int,
    out: np.ndarray,
) -> None:
    """Draw the image rows below the whole rows of sky into ``out`` (H - rows, W, ground's
    channels): the ground texture seen through one homography (texture pixels of
    ``world_to_ground``, 2x3, car placed by ``placed``, 3x3 car frame -> track), or through
    the lens's distortion (``remap_below_sky``)."""
    if camera.distorted:
        remap_below_sky(camera, ground, world_to_ground, placed, interpolation, out)
        return
    # image pixel -> ground point (car frame) -> track -> texture pixel; the affine steps keep
    # the homography's last row
    below = camera.below_sky_to_ground
    image_to_texture = np.empty((3, 3))
    image_to_texture[:2] = world_to_ground @ (placed @ below)
    image_to_texture[2] = below[2]
    warped = cv2.warpPerspective(
        ground,
        image_to_texture,
        (out.shape[1], out.shape[0]),
        dst=out,
        flags=interpolation | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=0,
    )
    assert warped is out, "cv2 wrote into its own array"


def remap_below_sky(
    camera: Pinhole,
    ground: np.ndarray,
    world_to_ground: np.ndarray,
    placed: np.ndarray,
    interpolation: int,
    out: np.ndarray,
) -> None:
    """``warp_below_sky`` for a distorting lens: the texture sampled at each pixel's ground
    point (``Pinhole.ground_points``), moved by the car's pose, by one ``cv2.remap``."""
    rows = camera.sky_rows
    ahead, right = camera.ground_points[:, rows:]
    to_texture = (world_to_ground @ placed).astype(np.float32)  # (2, 3) car frame -> texture
    (a, b, c), (d, e, f) = to_texture.tolist()
    map_x = ahead * np.float32(a) + right * np.float32(b) + np.float32(c)
    map_y = ahead * np.float32(d) + right * np.float32(e) + np.float32(f)
    done = cv2.remap(
        ground, map_x, map_y, interpolation, dst=out, borderMode=cv2.BORDER_CONSTANT, borderValue=0
    )
    assert done is out, "cv2 wrote into its own array"


def render(
    camera: Pinhole,
    ground: np.ndarray,
    world_to_ground: np.ndarray,
    placed: np.ndarray,
    sky: tuple[int, ...],
    interpolation: int = cv2.INTER_LINEAR,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """The camera image: ``ground`` (a texture, any channels) whose pixel coordinates are
    ``world_to_ground`` (2x3) of the track, seen from a car placed by ``placed`` (3x3, car
    frame -> track: ``car_to_world``);
    sky pixels set to ``sky`` (one value per channel of ``ground``)."""
    width, height = camera.size
    image = np.empty((height, width, *ground.shape[2:]), ground.dtype) if out is None else out
    if camera.sky_rows < height:
        below = image[camera.sky_rows :]
        warp_below_sky(camera, ground, world_to_ground, placed, interpolation, below)
    camera.sky_paint(tuple(sky), ground.shape[2:]).paint(image)
    return image
