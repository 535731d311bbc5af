"""What several sensor types share, apart from the types themselves (``sensors/*.py``):
mounts and ground maps (``common.py``), ray casting (``raycast*.py``, ``lidar_map.py``,
``other_cars.py``), the pinhole camera model (``pinhole.py``), and drawing: the other cars
on a view (``draw_cars.py``), CarRacing's car sprite and dashboard (``car_sprite.py``,
``dashboard.py``, ``drawing.py``). ``render/`` draws with them too.
"""
