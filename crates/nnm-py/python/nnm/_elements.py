"""The inputs of a general model: its nonlinear elements, and matrices in the form the native
module takes. The elements are checked by the library with the job file's rules."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from . import _checks


def _dofs(dofs: int | Sequence[int]) -> list[int]:
    """0-based dof numbers: an int or a sequence of ints, none negative."""
    if isinstance(dofs, (int, np.integer)):
        dofs = [int(dofs)]
    out = []
    for d in dofs:
        i = _checks.integer("dofs", d)  # TypeError for floats and strings, as for any index
        if i < 0:
            raise ValueError(f"dofs are 0-based and non-negative, got {i}")
        out.append(i)
    return out


@dataclass(frozen=True)
class Cubic:
    """A cubic spring: force ``c (x_i - x_j)^3`` on dof ``i`` and the opposite on dof ``j``.

    ``dofs`` is ``[i]`` (to ground) or ``[i, j]`` (between two dofs), 0-based; an int ``i``
    means ``[i]``. The job file's ``type = "cubic"``.
    """

    dofs: int | Sequence[int]
    coefficient: float

    def _spec(self) -> tuple:
        return ("cubic", _dofs(self.dofs), _checks.real("coefficient", self.coefficient), None)


@dataclass(frozen=True)
class Polynomial:
    """A polynomial spring ``c (x_i - x_j)^p``, any exponent ``p`` from 2 to 31 (odd powers
    keep the sign of the stretch, as a cubic's). The job file's ``type = "polynomial"``."""

    dofs: int | Sequence[int]
    coefficient: float
    exponent: int

    def _spec(self) -> tuple:
        exponent = _checks.integer("exponent", self.exponent)  # 64 bits, as in a job file
        return ("polynomial", _dofs(self.dofs), _checks.real("coefficient", self.coefficient), exponent)


def _terms(name: str, terms: Any, order: int) -> tuple[np.ndarray, np.ndarray]:
    """``(subs, values)`` of a tensor's terms as an ``m × order`` int64 array and ``m``
    float64 values. ``subs`` is one row per term (``i, j, k`` for ``f_i += c x_j x_k``), or
    scipy's form, a tuple of ``order`` index arrays."""
    if terms is None:
        return np.zeros((0, order), dtype=np.int64), np.zeros(0)
    subs, values = terms
    if isinstance(subs, tuple):
        subs = np.column_stack([np.asarray(s) for s in subs]) if subs else np.zeros((0, order))
    subs = np.asarray(subs)
    values = np.asarray(values)
    if values.dtype.kind not in "iuf":  # no strings read as numbers, no complex or booleans
        raise TypeError(f"{name} term values must be real numbers, got dtype {values.dtype}")
    values = values.astype(np.float64).reshape(-1)
    if subs.size == 0:
        subs = subs.reshape(0, order)
    if subs.ndim != 2 or subs.shape[1] != order:
        raise ValueError(
            f"{name} terms need indices of shape (m, {order}) (one row per term) or a tuple of "
            f"{order} index arrays, got shape {subs.shape}"
        )
    if subs.shape[0] != values.shape[0]:
        raise ValueError(f"{name} terms: {subs.shape[0]} index rows but {values.shape[0]} values")
    if subs.dtype.kind == "O" and all(
        not _checks.holds_bool(v) and hasattr(type(v), "__index__") for v in subs.flat
    ):  # Python ints beyond 64 bits: numpy keeps them as objects
        raise ValueError(f"{name} term index {max(subs.flat)} is out of range")
    if subs.dtype.kind not in "iu":
        raise TypeError(f"{name} term indices must be integers, got dtype {subs.dtype}")
    if subs.dtype.kind == "u" and subs.size and subs.max() >= 2**63:  # would wrap to negative
        raise ValueError(f"{name} term index {subs.max()} is out of range")
    if (subs < 0).any():
        raise ValueError(f"{name} term indices are 0-based and non-negative")
    return np.ascontiguousarray(subs, dtype=np.int64), np.ascontiguousarray(values)


@dataclass(frozen=True)
class Tensor:
    """Polynomial forces term by term, as finite-element codes export them:
    quadratic terms ``f_i += c x_j x_k`` and cubic terms ``f_i += c x_j x_k x_l``.

    ``quadratic=(subs, values)`` with ``subs`` an ``m × 3`` integer array (rows ``i, j, k``,
    0-based) or a tuple of three index arrays (scipy's COO form); ``cubic`` likewise with four
    indices. Repeated positions add up. The force must derive from a potential (the
    coefficients averaged over the trailing indices symmetric in all indices,
    docs/method.md eq. (59)), or the model is refused naming the two coefficients that differ.
    The job file's ``type = "tensor"`` (whose files count from 1).
    """

    quadratic: Any = None
    cubic: Any = None

    def _spec(self) -> tuple:
        if self.quadratic is None and self.cubic is None:
            raise ValueError("a tensor element needs `quadratic` and/or `cubic` terms")
        q = _terms("quadratic", self.quadratic, 3)
        c = _terms("cubic", self.cubic, 4)
        return ("tensor", q[0], q[1], c[0], c[1])


def _matrix(name: str, a: Any) -> Any:
    """A matrix as the native module takes it: a float64 2-D array, or for a scipy.sparse
    matrix its COO triplets (never a dense copy)."""
    if type(a).__module__.startswith("scipy.sparse"):
        coo = a.tocoo()
        if np.iscomplexobj(coo.data):
            raise TypeError(f"{name} matrix must be real, got dtype {coo.data.dtype}")
        if coo.data.dtype.kind not in "iuf":  # booleans are not numbers (a job file's true is not 1)
            raise TypeError(f"{name} matrix must be real numbers, got dtype {coo.data.dtype}")
        rows, cols = coo.shape
        return (
            int(rows),
            int(cols),
            np.ascontiguousarray(coo.row, dtype=np.int64),
            np.ascontiguousarray(coo.col, dtype=np.int64),
            np.ascontiguousarray(coo.data, dtype=np.float64),
        )
    array = np.asarray(a)
    if array.dtype.kind not in "iuf":  # booleans are not numbers (a job file's true is not 1)
        raise TypeError(f"{name} matrix must be real numbers, got dtype {array.dtype}")
    if _checks.holds_bool(a):  # [[True, 0.5], ...] reads as float64
        raise TypeError(f"{name} matrix must be real numbers, got bool")
    if array.ndim != 2:
        raise ValueError(f"{name} matrix must be 2-D, got shape {array.shape}")
    return np.ascontiguousarray(array, dtype=np.float64)
