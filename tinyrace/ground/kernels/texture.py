"""Compiled composition of a camera's affine with a texture level's (numba).

Imported only when numba imports (a dependency of tinyrace); see
``texture.compose_kernel``. ``shift_scale_matrix`` is ``texture.shift_scale_matrix`` bit
for bit: plain float64 products and sums (no fastmath), and in the shift column the
fused multiply-add that numpy's ``compose`` gets from OpenBLAS, as LLVM's ``llvm.fma``
(one rounding, in hardware or the C library's ``fma``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from tinyrace.kernels.compiled import compiler

_compile = compiler("texture")


def _fma_typing(typingctx: Any, x: Any, y: Any, z: Any) -> Any:
    """numba's signature and LLVM code of ``_fma(x, y, z)``: ``x * y + z`` rounded once."""
    signature = types.float64(types.float64, types.float64, types.float64)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        double = ir.DoubleType()
        function = builder.module.declare_intrinsic(
            "llvm.fma", [double], ir.FunctionType(double, [double, double, double])
        )
        return builder.call(function, args)

    return signature, codegen


_fma: Any = intrinsic(_fma_typing)


@_compile
def shift_scale_matrix(outer: Any, inner: Any) -> np.ndarray:
    """``compose(outer, inner)`` as a 2x3 array, for six-float affines whose ``inner`` has
    zero off-diagonal terms (``texture.compose_shift_scale``'s formulas)."""
    o00, o01, o02, o10, o11, o12 = outer
    sx, zero_01, tx, zero_10, sy, ty = inner
    matrix = np.empty((2, 3))
    matrix[0, 0] = o00 * sx + o01 * zero_10
    matrix[0, 1] = o00 * zero_01 + o01 * sy
    matrix[0, 2] = _fma(o01, ty, o00 * tx) + o02
    matrix[1, 0] = o10 * sx + o11 * zero_10
    matrix[1, 1] = o10 * zero_01 + o11 * sy
    matrix[1, 2] = _fma(o11, ty, o10 * tx) + o12
    return matrix
