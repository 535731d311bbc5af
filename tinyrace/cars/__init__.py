"""Car models: pymunk bodies driven by controls. The contract is ``cars/base.py``; the
models, the track kinds each supports and their action spaces are in ``cars/registry.py``."""
