"""The ground: the track textures an episode's sensors and pictures sample.

``grounds.py`` chooses and serves an env's ground (``make_ground``, ``EpisodeGround``);
``texture.py`` is a picture with its affine to the track; ``procedural.py`` paints
CarRacing's ground, ``metric.py`` draws a fixed track's from what it holds. Below both
``sensors/`` and ``render/``: neither paints a ground of its own.
"""
