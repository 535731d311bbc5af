"""The sensors layer's compiled (numba) kernels, each named as its plain twin:

- ``raycast.py``: the lidar's ray casting (``sensors/machinery/raycast_numpy.py``;
  TINYRACE_LIDAR);
- ``cones.py``: the cone detector (``sensors/cones.py``'s numpy path; TINYRACE_CONES);
- ``drawing.py``: CarRacing's dashboard bars and car blend
  (``sensors/machinery/drawing.py``'s numpy path; TINYRACE_DRAWING).

Same results as the plain twin, bit for bit; imported only when ``tinyrace.kernels.choose``
picks it (numba installed: ``pip install tinyrace[fast]``).
"""
