"""Models: general ones from M, K and nonlinear elements, job files, and the built-in families.

Everything a model may be is checked by the library with the job file's rules, so a model
refused here is refused by ``nnm run`` with the same message (without the file's name).
"""

from __future__ import annotations

import operator
import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Iterable, Sequence

import numpy as np

from . import _nnm

if TYPE_CHECKING:
    import pandas

    from ._branch import Branch


def _dofs(dofs: int | Sequence[int]) -> list[int]:
    """0-based dof numbers: an int or a sequence of ints, none negative."""
    if isinstance(dofs, (int, np.integer)):
        dofs = [int(dofs)]
    out = []
    for d in dofs:
        i = operator.index(d)  # TypeError for floats and strings, as for any index
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
        return ("cubic", _dofs(self.dofs), float(self.coefficient), None)


@dataclass(frozen=True)
class Polynomial:
    """A polynomial spring ``c (x_i - x_j)^p``, any exponent ``p`` from 2 to 31 (odd powers
    keep the sign of the stretch, as a cubic's). The job file's ``type = "polynomial"``."""

    dofs: int | Sequence[int]
    coefficient: float
    exponent: int

    def _spec(self) -> tuple:
        return ("polynomial", _dofs(self.dofs), float(self.coefficient), operator.index(self.exponent))


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
    values = np.asarray(values, dtype=np.float64).reshape(-1)
    if subs.size == 0:
        subs = subs.reshape(0, order)
    if subs.ndim != 2 or subs.shape[1] != order:
        raise ValueError(
            f"{name} terms need indices of shape (m, {order}) (one row per term) or a tuple of "
            f"{order} index arrays, got shape {subs.shape}"
        )
    if subs.shape[0] != values.shape[0]:
        raise ValueError(f"{name} terms: {subs.shape[0]} index rows but {values.shape[0]} values")
    if subs.dtype.kind not in "iu":
        raise TypeError(f"{name} term indices must be integers, got dtype {subs.dtype}")
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
        rows, cols = coo.shape
        return (
            int(rows),
            int(cols),
            np.ascontiguousarray(coo.row, dtype=np.int64),
            np.ascontiguousarray(coo.col, dtype=np.int64),
            np.ascontiguousarray(coo.data, dtype=np.float64),
        )
    array = np.asarray(a)
    if array.dtype.kind not in "biuf":
        raise TypeError(f"{name} matrix must be real numbers, got dtype {array.dtype}")
    if array.ndim != 2:
        raise ValueError(f"{name} matrix must be 2-D, got shape {array.shape}")
    return np.ascontiguousarray(array, dtype=np.float64)


class Model:
    """A conservative structure ``M x'' + K x + f_nl(x) = 0``.

    ``Model(M, K, nonlinear=[...], fixed_dofs=None, cyclic=None)``: ``M`` and ``K`` are square
    numpy arrays or scipy.sparse matrices of the same size (sparse ones stay sparse: no
    ``n × n`` copy is made), symmetric to 1e-10 of their largest entry, finite, ``M``
    positive definite. ``nonlinear`` lists :class:`Cubic`, :class:`Polynomial` and
    :class:`Tensor` elements, in the numbering of ``M`` and ``K``. ``fixed_dofs`` (0-based)
    are held at zero and removed, the elements following (every output is then in the
    reduced numbering: the free dofs in ascending order). ``cyclic=(sectors,
    dofs_per_sector)`` declares a cyclic symmetry with sector-major numbering, which gives the
    modes ``(n, d)`` labels.

    Other constructors: :meth:`from_job` and the families :func:`bladed_disk`,
    :func:`duffing`, :func:`two_dof`, :func:`cantilever_beam`, :func:`von_karman_beam`.
    Bad input raises ``ValueError`` or ``TypeError`` with the message ``nnm run`` gives.
    """

    _native: Any

    def __init__(
        self,
        M: Any,
        K: Any,
        nonlinear: Iterable[Cubic | Polynomial | Tensor] = (),
        fixed_dofs: Sequence[int] | None = None,
        cyclic: tuple[int, int] | None = None,
    ) -> None:
        elements = []
        for k, element in enumerate(nonlinear):
            if not hasattr(element, "_spec"):
                raise TypeError(
                    f"nonlinear element {k + 1} must be nnm.Cubic, nnm.Polynomial or nnm.Tensor, "
                    f"got {type(element).__name__}"
                )
            try:
                elements.append(element._spec())
            except ValueError as e:
                raise ValueError(f"nonlinear element {k + 1}: {e}") from None
        fixed = None if fixed_dofs is None else _dofs(fixed_dofs)
        if cyclic is not None:
            cyclic = (operator.index(cyclic[0]), operator.index(cyclic[1]))
        self._native = _nnm.NativeModel.general(
            _matrix("mass", M), _matrix("stiffness", K), elements, fixed, cyclic
        )

    @classmethod
    def _wrap(cls, native: Any) -> "Model":
        model = cls.__new__(cls)
        model._native = native
        return model

    @classmethod
    def from_job(cls, path: str | os.PathLike, overrides: dict[str, Any] | None = None) -> "Model":
        """The model of a job file (TOML), read exactly as ``nnm run`` reads it (Matrix
        Market and tensor files resolved relative to it). Its branches are in
        :attr:`branches`; ``nnm.backbone(model, branch=NAME)`` runs one as ``nnm run``
        would.

        ``overrides`` replaces keys of the file, as a parameter study varies them: dotted
        keys ``"model.KEY"``, ``"settings.KEY"`` or ``"branch.NAME.KEY"`` with the values
        the file would hold, e.g. ``{"model.cubic": 0.2, "branch.mode-1-5.energy_max": 5}``
        (the blade mistuning of a bladed disk is ``"model.blade_stiffness_mistuning"``, one
        relative deviation per sector)."""
        return cls._wrap(_nnm.NativeModel.from_job(os.fspath(path), overrides))

    @classmethod
    def _family(cls, family: str, parameters: dict[str, Any]) -> "Model":
        return cls._wrap(_nnm.NativeModel.from_table({"family": family, **parameters}))

    @property
    def dofs(self) -> int:
        """Number of degrees of freedom (after ``fixed_dofs`` are removed)."""
        return self._native.dofs

    @property
    def family(self) -> str:
        """``"bladed-disk"``, ``"duffing"``, ``"two-dof"``, ``"cantilever-beam"``,
        ``"von-karman-beam"`` or ``"general"``."""
        return self._native.family

    @property
    def cyclic(self) -> tuple[int, int] | None:
        """``(sectors, dofs_per_sector)`` of a cyclic model, else ``None``."""
        return self._native.cyclic

    @property
    def branches(self) -> list[str]:
        """Names of the ``[[branch]]`` entries of the job file the model came from."""
        return self._native.branch_names

    def _matrix(self, name: str) -> Any:
        m = self._native.matrix(name)
        if isinstance(m, tuple):
            import scipy.sparse

            n, indptr, indices, data = m
            return scipy.sparse.csr_array((data, indices, indptr), shape=(n, n))
        return m

    @property
    def M(self) -> Any:
        """The mass matrix as held: a numpy array, or a scipy.sparse CSR array when sparse."""
        return self._matrix("mass")

    @property
    def K(self) -> Any:
        """The stiffness matrix as held (see :attr:`M`)."""
        return self._matrix("stiffness")

    def modes(self) -> "Modes":
        """The linear modes (see :func:`nnm.modes`)."""
        return modes(self)

    def backbone(self, mode: Any = None, **kwargs: Any) -> "Branch":
        """Follows a branch of this model (see :func:`nnm.backbone`)."""
        from ._branch import backbone

        return backbone(self, mode, **kwargs)

    def __repr__(self) -> str:
        cyclic = f", cyclic={self.cyclic}" if self.cyclic else ""
        return f"<nnm.Model {self.family}, {self.dofs} dofs{cyclic}>"


@dataclass(frozen=True)
class Modes:
    """Linear modes in ascending frequency.

    ``frequencies`` in rad/s (0 for rigid-body modes); ``shapes[:, k]`` is mode ``k``,
    mass-normalised (``shapes.T @ M @ shapes = I``); ``rigid[k]`` marks rigid-body modes;
    ``labels[k]`` is ``(n, d)`` (nodal circles, nodal diameters) on cyclic models, else
    ``None``, and ``patterns[k]`` ``"cos"``/``"sin"`` for the two standing waves of a
    degenerate pair. ``nnm.backbone(model, mode=...)`` takes an index ``k``, a label ``(n, d)``
    or ``"n,d"`` (with ``pattern=`` for the ``sin`` wave).
    """

    frequencies: np.ndarray
    shapes: np.ndarray
    rigid: np.ndarray
    labels: list[tuple[int, int] | None] = field(default_factory=list)
    patterns: list[str | None] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.frequencies)

    def index(self, label: tuple[int, int] | str, pattern: str = "cos") -> int:
        """The index of the mode labelled ``(n, d)`` (the ``pattern`` wave of a pair)."""
        wanted = _label(label)
        for k, (lab, pat) in enumerate(zip(self.labels, self.patterns)):
            if lab is not None and f"{lab[0]},{lab[1]}" == wanted and pat in (None, pattern):
                return k
        raise ValueError(f"unknown mode `{wanted}`")

    def to_pandas(self) -> "pandas.DataFrame":
        """One row per mode: ``frequency_rad_s``, ``label``, ``pattern``, ``rigid`` (the
        columns of ``modes.csv``)."""
        import pandas

        return pandas.DataFrame(
            {
                "frequency_rad_s": self.frequencies,
                "label": [None if lab is None else f"{lab[0]},{lab[1]}" for lab in self.labels],
                "pattern": self.patterns,
                "rigid": self.rigid,
            }
        )


def _parse_label(text: str | None) -> tuple[int, int] | None:
    """``"n,d"`` (as the library writes labels) as ``(n, d)``."""
    if text is None:
        return None
    n, d = text.split(",")
    return int(n), int(d)


def _label(label: Any) -> str:
    if isinstance(label, tuple):
        n, d = label
        return f"{operator.index(n)},{operator.index(d)}"
    return str(label)


def modes(model: Model) -> Modes:
    """Linear modes of ``model`` in ascending frequency, as ``nnm modes`` lists them (all of
    them; the 20 lowest for sparse models above 2,000 dofs). Every mode is checked against
    ``K`` and ``M`` as given (docs/method.md §10)."""
    raw = model._native.modes()
    labels = [_parse_label(s) for s in raw["label"]]
    return Modes(raw["frequency"], raw["shapes"], raw["rigid"], labels, raw["pattern"])


# The built-in families: the job file's `family = "..."` with its keys as keyword arguments and
# the same defaults (tests/test_models.py checks that they agree with the job file's).


def bladed_disk(
    *,
    sectors: int = 30,
    disk_mass: float = 1.0,
    blade_mass: float = 0.3,
    disk_coupling: float = 1.0,
    blade_stiffness: float = 1.0,
    cubic: float = 0.1,
    blade_stiffness_mistuning: Sequence[float] | None = None,
) -> Model:
    """The paper's bladed disk (docs/method.md §11): ``sectors`` sectors of a disk mass
    ``disk_mass`` (M) and a blade mass ``blade_mass`` (m), disks coupled by ``disk_coupling``
    (K), each blade on its disk by a linear spring ``blade_stiffness`` (k) and a cubic one
    ``cubic`` (knl). Dof ``2i`` is the disk of sector ``i``, ``2i + 1`` its blade; cyclic, so
    modes are labelled ``(n, d)`` (Table 1 of the paper with the defaults).

    ``blade_stiffness_mistuning`` (one relative deviation ``δ_i > -1`` per sector) mistunes
    the blades, ``k_i = k (1 + δ_i)``; a mistuned disk is not cyclic (its modes are
    unlabelled, its pairs split)."""
    parameters = dict(locals())
    if blade_stiffness_mistuning is not None:
        parameters["blade_stiffness_mistuning"] = [float(d) for d in blade_stiffness_mistuning]
    return Model._family("bladed-disk", parameters)


def duffing(*, natural_frequency: float = 1.0, cubic: float = 1.0) -> Model:
    """The Duffing oscillator ``x'' + w0^2 x + a x^3 = 0`` (``w0 = natural_frequency``,
    ``a = cubic``), whose backbone has an exact elliptic period."""
    return Model._family("duffing", locals())


def two_dof(*, cubic: float = 0.5) -> Model:
    """The two-DOF system of Kerschen et al. (2009): ``x1'' + (2 x1 - x2) + c x1^3 = 0``,
    ``x2'' + (2 x2 - x1) = 0`` with ``c = cubic``."""
    return Model._family("two-dof", locals())


def cantilever_beam(
    *,
    elements: int = 19,
    length: float = 0.7,
    width: float = 0.014,
    height: float = 0.014,
    youngs_modulus: float = 2.05e11,
    density: float = 7800.0,
    cubic: float = 6e9,
) -> Model:
    """The ECL cantilever beam of NLvib's example 09: Euler–Bernoulli finite elements
    (deflection and rotation per node, consistent mass), clamped at one end, a cubic spring
    ``cubic`` (N/m^3) from the tip to ground. SI units."""
    return Model._family("cantilever-beam", locals())


def von_karman_beam(
    *,
    elements: int = 20,
    length: float = 1.0,
    width: float = 0.1,
    thickness: float = 0.01,
    youngs_modulus: float = 70e9,
    density: float = 2700.0,
) -> Model:
    """A clamped-clamped von Kármán beam: axial and transverse dofs per node, with the exact
    quadratic and cubic forces of the membrane stretch. SI units."""
    return Model._family("von-karman-beam", locals())
