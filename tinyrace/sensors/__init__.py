"""Sensors: what the car perceives, each one module reading a snapshot of the world."""
