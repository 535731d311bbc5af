"""The ground layer's compiled (numba) kernels, each named as its plain twin:

- ``texture.py``: the ground texture's affine composition (``ground/texture.py``;
  TINYRACE_DRAWING).

Same results as the plain twin, bit for bit; imported only when ``tinyrace.kernels.choose``
picks it (numba installed: ``pip install tinyrace[fast]``).
"""
