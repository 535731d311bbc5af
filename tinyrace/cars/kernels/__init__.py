"""The cars layer's compiled (numba) kernels, each named as its plain twin:

- ``dynamic.py``: the dynamic car's tyre model, one car or a batch
  (``cars/dynamic_python.py``; TINYRACE_PHYSICS).

Same results as the plain twin, bit for bit; imported only when ``tinyrace.kernels.choose``
picks it (numba installed: ``pip install tinyrace[fast]``).
"""
