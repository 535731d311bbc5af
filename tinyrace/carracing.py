"""tinyrace/CarRacing-v0: a drop-in for Gymnasium's CarRacing-v3 with its constructor."""

from __future__ import annotations

from tinyrace.env import TinyRaceEnv
from tinyrace.env_checks import flag


class CarRacingEnv(TinyRaceEnv):
    """CarRacing-v3's kwargs on tinyrace's procedural track (see TinyRaceEnv for the rest)."""

    def __init__(
        self,
        render_mode: str | None = None,
        verbose: bool = False,
        lap_complete_percent: float = 0.95,
        domain_randomize: bool = False,
        continuous: bool = True,
    ):
        # each a bool, as CarRacing-v3 reads them, not any truthy object: "no" would be true
        continuous = flag(continuous, "continuous")
        domain_randomize = flag(domain_randomize, "domain_randomize")
        super().__init__(
            config={
                "track": {
                    "type": "procedural",
                    "lap_complete_percent": lap_complete_percent,
                    "domain_randomize": domain_randomize,
                },
                "car": {"model": "dynamic", "actions": "continuous" if continuous else "discrete"},
            },
            render_mode=render_mode,
            verbose=verbose,
        )
