"""Named views of a batch of cell states and inputs, for numpy or torch arrays."""

from __future__ import annotations

from typing import Any

from array_api_compat import array_namespace

Array = Any  # a numpy.ndarray or a torch.Tensor


class CellVariables:
    """States x (..., 8) and inputs u (..., 5) by name, plus the bath composition.

    ``m`` is the bath mass x2 + x3 + x4 [kg]; ``c2``, ``c3`` the Al2O3 and AlF3
    mass fractions [-]; ``p2``, ``p3`` the same in percent.  ``xp`` is the array
    namespace (numpy or torch) every part must use for elementwise functions.
    """

    __slots__ = (
        "xp", "x", "u",
        "x1", "x2", "x3", "x4", "x5", "x6", "x7", "x8",
        "u1", "u2", "u3", "u4", "u5",
        "m", "c2", "c3", "p2", "p3",
    )  # fmt: skip

    def __init__(self, x: Array, u: Array):
        if x.shape[-1] != 8 or u.shape[-1] != 5:
            raise ValueError(
                f"states must end in 8 and inputs in 5 values, got shapes {tuple(x.shape)} and {tuple(u.shape)}"
            )
        self.xp = array_namespace(x, u)
        self.x, self.u = x, u
        (self.x1, self.x2, self.x3, self.x4,
         self.x5, self.x6, self.x7, self.x8) = (x[..., i] for i in range(8))  # fmt: skip
        self.u1, self.u2, self.u3, self.u4, self.u5 = (u[..., i] for i in range(5))
        self.m = self.x2 + self.x3 + self.x4
        self.c2 = self.x2 / self.m
        self.c3 = self.x3 / self.m
        self.p2 = 100 * self.c2
        self.p3 = 100 * self.c3
