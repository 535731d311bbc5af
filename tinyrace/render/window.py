"""The human window: pygame, imported only when a window is asked for."""

from __future__ import annotations

import os
import sys
import time
from typing import Any

import numpy as np
from gymnasium.error import DependencyNotInstalled


class NoDisplay(RuntimeError):
    """``render_mode="human"`` where no window can open: no display, no SDL driver chosen."""


def display_missing() -> str | None:
    """Why a window cannot open here, or None: on Linux, no ``DISPLAY`` or
    ``WAYLAND_DISPLAY`` and no ``SDL_VIDEODRIVER`` set (pygame would then draw to its
    offscreen driver and show nothing). A driver set explicitly is taken as chosen: the
    tests' ``dummy``, ``offscreen``, ``kmsdrm`` on a console."""
    if not sys.platform.startswith("linux"):
        return None
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return None
    if os.environ.get("SDL_VIDEODRIVER"):
        return None
    return (
        'render_mode="human" needs a display: no DISPLAY or WAYLAND_DISPLAY is set. Use '
        'render_mode="rgb_array" for the frames, or set SDL_VIDEODRIVER=dummy to draw '
        "into no window"
    )


class Window:
    """Shows RGB frames; optionally paces them to ``fps``."""

    def __init__(self, title: str, fps: float):
        try:
            import pygame
        except ImportError as exc:
            raise DependencyNotInstalled(
                'render_mode="human" needs pygame: pip install "tinyrace[human]" (pygame-ce)'
            ) from exc
        missing = display_missing()
        if missing is not None:
            raise NoDisplay(missing)
        self.pygame = pygame
        self.title = title
        self.fps = fps
        self.screen: Any = None  # the pygame display surface, once shown
        self._last = 0.0

    def show(self, frame: np.ndarray, realtime: bool = True) -> None:
        pygame = self.pygame
        height, width = frame.shape[:2]
        if self.screen is None or self.screen.get_size() != (width, height):
            try:
                pygame.display.init()
                pygame.display.set_caption(self.title)
                self.screen = pygame.display.set_mode((width, height))
            except pygame.error as exc:  # no such SDL driver, no video device
                driver = os.environ.get("SDL_VIDEODRIVER")
                chosen = f" (SDL_VIDEODRIVER={driver})" if driver else ""
                raise NoDisplay(
                    f'render_mode="human" cannot open a window{chosen}: {exc}. Use '
                    'render_mode="rgb_array" for the frames, or SDL_VIDEODRIVER=dummy'
                ) from None
        pygame.event.pump()
        surface = pygame.surfarray.make_surface(np.ascontiguousarray(frame.transpose(1, 0, 2)))
        self.screen.blit(surface, (0, 0))
        if realtime:
            wait = self._last + 1.0 / self.fps - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            self._last = time.perf_counter()
        pygame.display.flip()

    def close(self) -> None:
        if self.screen is not None:
            self.pygame.display.quit()
            self.screen = None
