"""Sensors: each turns a world snapshot and the track into one observation.

The contract is ``sensors/base.py``; the sensor types by ``type`` are in
``sensors/registry.py``.
"""
