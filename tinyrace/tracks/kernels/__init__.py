"""The tracks layer's compiled (numba) kernels, each named as its plain twin:

- ``procedural.py``: the procedural track's path loop (``tracks/procedural.py``'s
  ``trace_path``; TINYRACE_TRACE).

Same results as the plain twin, bit for bit; imported only when ``tinyrace.kernels.choose``
picks it (numba installed: ``pip install tinyrace[fast]``).
"""
