"""The render layer's compiled (numba) kernels, each named as its plain twin:

- ``drawing.py``: CarRacing's dashboard bars and car blend (``render/drawing.py``'s numpy
  path; TINYRACE_DRAWING).

Same results as the plain twin, bit for bit; imported only when ``tinyrace.kernels.choose``
picks it (numba installed: ``pip install tinyrace[fast]``).
"""
