"""CarRacing's car as plain numbers: its shape and constants, with no physics engine.

``cars/dynamic.py`` builds the pymunk car from these; sensors and pictures read them
without importing pymunk.
"""

from __future__ import annotations

from dataclasses import dataclass

SIZE = 0.02  # [u per model unit] CarRacing's car model scale

HULL_POLYGONS = (  # [model units], the nose along +y
    ((-60, 130), (60, 130), (60, 110), (-60, 110)),
    ((-15, 120), (15, 120), (20, 20), (-20, 20)),
    ((25, 20), (50, -10), (50, -40), (20, -90), (-20, -90), (-50, -40), (-50, -10), (-25, 20)),
    ((-50, -120), (50, -120), (50, -90), (-50, -90)),
)
WHEEL_POSITIONS = ((-55, 80), (55, 80), (-55, -82), (55, -82))  # [model units] FL, FR, RL, RR
WHEEL_RADIUS = 27  # [model units]
WHEEL_HALF_WIDTH = 14  # [model units]


@dataclass(frozen=True)
class DynamicCarSpec:
    """CarRacing-v3's car constants, in world units (u), kilograms-ish and seconds."""

    hull_density: float = 1.0  # [mass/u^2]
    wheel_density: float = 0.1  # [mass/u^2]
    engine_power: float = 1e8 * SIZE**2  # [mass u^2/s^3]
    wheel_moment: float = 4000 * SIZE**2  # [mass u^2]
    friction_limit: float = 1e6 * SIZE**2  # [mass u/s^2] on road; grass has grass_friction of it
    grass_friction: float = 0.6  # fraction of the road's friction limit
    slip_gain: float = 205000 * SIZE**2  # [mass/s] tyre force per unit of slip speed
    brake_rate: float = 15.0  # [rad/s per step] spin removed by full (non-locking) brake
    brake_lock: float = 0.9  # brake input at which the wheels lock
    gas_rise: float = 0.1  # max gas increase per step
    steer_gain: float = 50.0  # [1/s] steering motor speed per rad of error
    steer_speed: float = 3.0  # [rad/s] max steering motor speed
    steer_limit: float = 0.4  # [rad] front wheel lock
    max_translation: float = 2.0  # [u per step] Box2D's speed cap, kept for identical top speed
    spin_floor: float = 5.0  # [rad/s] added to |spin| where the engine's torque is divided by it
    skid_ratio: float = 2.0  # a tyre skids (draws a mark) beyond this multiple of its grip
