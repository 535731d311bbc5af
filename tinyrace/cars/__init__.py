"""Car models: pymunk bodies driven by controls. The contract is ``cars/base.py``; the
models, the track kinds each supports and their action spaces are in ``cars/registry.py``.

The layer's public names for the layers above: ``CarRacingCar`` (CarRacing-v3's car: its
size and steering servo, which the drivers' defaults and CarRacing's discrete actions are
tuned for) and ``CARRACING_WHEELBASE`` [u], its axle to axle.
"""

from tinyrace.cars.dynamic_shape import SIZE as _SIZE
from tinyrace.cars.dynamic_shape import DynamicCarSpec as CarRacingCar

CARRACING_WHEELBASE = (80 + 82) * _SIZE  # [u] axle to axle of CarRacing's car

__all__ = ["CARRACING_WHEELBASE", "CarRacingCar"]
