"""Track sources: each turns the config's ``track`` sections into read-only ``Track`` data.

The contract is in ``tracks/base.py``; the sources by ``track.type`` are listed in
``tracks/registry.py``.
"""
