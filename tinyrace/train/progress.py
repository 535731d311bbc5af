"""``tinyrace train``'s progress bar: a Stable-Baselines3 callback (imported with SB3 only)."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from tqdm import tqdm

REFRESH = 0.5  # [s] between updates of the recent mean return
RECENT = 20  # episodes in the recent mean return


class Progress(BaseCallback):  # type: ignore[misc, unused-ignore]  # Any where SB3 is absent
    """A tqdm bar on stderr (steps done, steps/s, the mean return of the last ``RECENT``
    episodes) when ``show``. ``check`` gets each step's infos: the trainer's raises when
    an env reported an exception."""

    def __init__(self, total: int, check: Callable[[Any], None], show: bool = True):
        super().__init__()
        self.total = total
        self.check = check
        self.show = show
        self.bar: tqdm[None] | None = None
        self._shown = 0.0  # when the return was last written

    def _on_training_start(self) -> None:
        if self.show:
            self.bar = tqdm(
                total=self.total, desc="training", unit="step", file=sys.stderr, smoothing=0.1
            )

    def _on_step(self) -> bool:
        self.check(self.locals.get("infos"))
        if self.bar is not None:
            self.bar.update(min(self.training_env.num_envs, self.total - self.bar.n))
            if time.monotonic() - self._shown > REFRESH:
                self.bar.set_postfix_str(self._recent(), refresh=False)
                self._shown = time.monotonic()
        return True

    def _recent(self) -> str:
        episodes = list(self.model.ep_info_buffer or ())[-RECENT:]
        if not episodes:
            return "return: no episode ended yet"
        mean = float(np.mean([e["r"] for e in episodes]))
        return f"return {mean:.1f} (mean of the last {len(episodes)} episodes)"

    def _on_training_end(self) -> None:
        self.close()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(self._recent())
            self.bar.close()
            self.bar = None
