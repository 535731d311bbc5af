"""The human window: pygame, imported only when a window is asked for."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from gymnasium.error import DependencyNotInstalled


class Window:
    """Shows RGB frames; optionally paces them to ``fps``."""

    def __init__(self, title: str, fps: float):
        try:
            import pygame
        except ImportError as exc:
            raise DependencyNotInstalled(
                'render_mode="human" needs pygame: pip install "tinyrace[human]" (pygame-ce)'
            ) from exc
        self.pygame = pygame
        self.title = title
        self.fps = fps
        self.screen: Any = None  # the pygame display surface, once shown
        self._last = 0.0

    def show(self, frame: np.ndarray, realtime: bool = True) -> None:
        pygame = self.pygame
        height, width = frame.shape[:2]
        if self.screen is None or self.screen.get_size() != (width, height):
            pygame.display.init()
            pygame.display.set_caption(self.title)
            self.screen = pygame.display.set_mode((width, height))
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
