"""The physics world: a pymunk space with the track's static shapes and the cars.

No pictures and no Gymnasium here: controls and a time step in, facts and a
``Snapshot`` (``world/snapshot.py``) out.
"""
