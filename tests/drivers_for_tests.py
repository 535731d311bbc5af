"""A user's own driver, as an experiment file names it: ``drivers_for_tests:straight_policy``."""

import numpy as np


def straight_policy():
    """A factory returning a plain policy function (observation, info) -> action."""
    return lambda observation, info: np.array([0.0, 0.3, 0.0], np.float32)


def shaped_policy(shape=(2,)):
    """A policy returning actions of the wrong shape."""
    return lambda observation, info: np.zeros(shape, np.float32)


def nan_policy():
    return lambda observation, info: np.array([np.nan, 0.3, 0.0], np.float32)


def failing_policy(after: int = 0):
    """A policy that raises at step ``after``."""
    steps = []

    def policy(observation, info):
        steps.append(1)
        if len(steps) > after:
            raise RuntimeError("the policy broke")
        return np.array([0.0, 0.3, 0.0], np.float32)

    return policy


def failing_factory():
    raise RuntimeError("no model file")


def slow_policy(delay: float = 0.002, size: int = 3):
    """Straight ahead, slowly: long enough runs to be interrupted (size 1: kinematic car)."""
    import time

    def policy(observation, info):
        time.sleep(delay)
        return np.array([0.0, 0.3, 0.0][:size], np.float32)

    return policy
