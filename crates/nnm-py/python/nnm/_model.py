"""Models: general ones from M, K and nonlinear elements, job files, and the built-in families;
their linear modes and the branches that start from them.

Everything a model may be is checked by the library with the job file's rules, so a model
refused here is refused by ``nnm run`` with the same message (without the file's name).
"""

from __future__ import annotations

import functools
import inspect
import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Iterable, Sequence

import numpy as np

from . import _checks, _nnm
from ._branch import Branch, _follow, _options
from ._elements import Cubic, Polynomial, Tensor, _dofs, _matrix
from ._force import Force
from ._labels import _label, _parse_label

if TYPE_CHECKING:
    import pandas


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

    Damping, for forced responses (:func:`nnm.frequency_response`): ``C=`` a matrix (numpy,
    scipy.sparse or nested lists, symmetric positive semi-definite, in the numbering of ``M``
    and ``K``: before ``fixed_dofs``, whose rows and columns it loses), or ``damping=`` one
    of the job file's ``[model] damping`` forms, read and built by the same functions:
    ``{"rayleigh": [α, β]}`` (``C = αM + βK``), ``{"modal": [ζ1, ζ2, ...]}`` (ratios of the
    lowest elastic modes), ``{"matrix": C}`` (as ``C=``) or ``{"file": "C.mtx"}`` (Matrix
    Market, relative to the working directory); the families (:func:`duffing`, ...) take the
    same ``damping=`` keyword, and a job file's model (:meth:`from_job`) has its own. The
    damping is kept beside the conservative model (branches and modes ignore it);
    :meth:`with_damping` gives the same model with another. A negative, non-finite or
    indefinite damping raises ``ValueError`` with the job file's message (naming the entry or
    eigenvalue).

    Other constructors: :meth:`from_job` and the families :func:`bladed_disk`,
    :func:`duffing`, :func:`two_dof`, :func:`cantilever_beam`, :func:`von_karman_beam`,
    :func:`solid`.
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
        *,
        C: Any = None,
        damping: Any = None,
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
            except (ValueError, TypeError) as e:
                raise type(e)(f"nonlinear element {k + 1}: {e}") from None
        fixed = None if fixed_dofs is None else _dofs(fixed_dofs)
        if cyclic is not None:
            if isinstance(cyclic, (str, bytes)) or not hasattr(cyclic, "__len__") or len(cyclic) != 2:
                raise TypeError(f"cyclic must be (sectors, dofs_per_sector), got {cyclic!r}")
            cyclic = (_checks.integer("cyclic sectors", cyclic[0]), _checks.integer("cyclic dofs_per_sector", cyclic[1]))
            if min(cyclic) < 1:
                raise ValueError(f"cyclic=(sectors, dofs_per_sector) must be positive, got {cyclic}")
        self._native = _nnm.NativeModel.general(
            _matrix("mass", M), _matrix("stiffness", K), elements, fixed, cyclic
        )
        if C is not None and damping is not None:
            raise TypeError("give the damping either as `C` (a matrix) or as `damping`, not both")
        self._set_damping(C if C is not None else damping)

    def _set_damping(self, damping: Any) -> None:
        """Builds and checks ``C`` for this model (the library's forms and messages) and keeps
        it beside the conservative model, which never holds it."""
        self._damping_spec = damping
        self._damping = None if damping is None else _nnm.damping(self._native, _damping_form(damping))

    def with_damping(self, damping: Any) -> "Model":
        """This model with ``damping`` instead of its own (the forms of ``Model(damping=...)``),
        sharing the conservative model: e.g. a job file's model,
        ``Model.from_job(path).with_damping({"rayleigh": [0, 1e-4]})``."""
        model = Model._wrap(self._native)
        model._set_damping(damping)
        return model

    @property
    def damping(self) -> Any:
        """The damping as given (a dict form, a matrix; a job file's as the file writes it),
        or ``None`` (undamped)."""
        return self._damping_spec

    @classmethod
    def _wrap(cls, native: Any) -> "Model":
        model = cls.__new__(cls)
        model._native = native
        # A job file's `[model] damping`, built when the file was read.
        job_damping = native.job_damping()
        model._damping_spec, model._damping = (None, None) if job_damping is None else job_damping
        return model

    @classmethod
    def from_job(cls, path: str | os.PathLike, overrides: dict[str, Any] | None = None) -> "Model":
        """The model of a job file (TOML), read exactly as ``nnm run`` reads it (Matrix
        Market and tensor files resolved relative to it). Its branches are in
        :attr:`branches`; ``nnm.backbone(model, branch=NAME)`` runs one as ``nnm run``
        would. Its ``[model] damping``, if any, is the model's damping (:attr:`damping`), which
        :func:`nnm.frequency_response` uses.

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

    @property
    def responses(self) -> list[str]:
        """Names of the ``[[response]]`` entries of the job file the model came from."""
        return self._native.response_names

    def _matrix(self, name: str) -> Any:
        return _scipy_or_dense(self._native.matrix(name))

    @property
    def M(self) -> Any:
        """The mass matrix as held: a numpy array, or a scipy.sparse CSR array when sparse."""
        return self._matrix("mass")

    @property
    def K(self) -> Any:
        """The stiffness matrix as held (see :attr:`M`)."""
        return self._matrix("stiffness")

    def internal_force(self, x: Any) -> Any:
        """The internal force ``f_int(x) = K x + f_nl(x)`` (a numpy array) at the displacement
        ``x`` (``dofs`` finite values): to check a model against one's own code."""
        return self._native.internal_force(_displacement(x))

    def tangent_stiffness(self, x: Any) -> Any:
        """The tangent stiffness ``K_t(x) = ∂f_int/∂x`` at ``x``: a scipy.sparse CSR array on
        the model's fixed pattern (every model built from ``M``, ``K`` and elements has one), or
        a numpy array."""
        return _scipy_or_dense(self._native.tangent_stiffness(_displacement(x)))

    def modes(self) -> "Modes":
        """The linear modes (see :func:`nnm.modes`)."""
        return modes(self)

    def backbone(self, mode: Any = None, **kwargs: Any) -> "Branch":
        """Follows a branch of this model (see :func:`nnm.backbone`)."""
        return backbone(self, mode, **kwargs)

    def __repr__(self) -> str:
        cyclic = f", cyclic={self.cyclic}" if self.cyclic else ""
        damped = ", damped" if self._damping is not None else ""
        return f"<nnm.Model {self.family}, {self.dofs} dofs{cyclic}{damped}>"


def _scipy_or_dense(m: Any) -> Any:
    """A native matrix as Python has it: ``(n, indptr, indices, data)`` of compressed sparse rows
    becomes a scipy.sparse CSR array, a dense array stays as it is."""
    if isinstance(m, tuple):
        import scipy.sparse

        n, indptr, indices, data = m
        return scipy.sparse.csr_array((data, indices, indptr), shape=(n, n))
    return m


def _displacement(x: Any) -> Any:
    """``x`` as a one-dimensional float64 array (the native methods check its length)."""
    array = np.ascontiguousarray(x, dtype=np.float64)
    if array.ndim != 1:
        raise ValueError(f"x must be one-dimensional, got shape {array.shape}")
    return array


def _damping_form(damping: Any) -> Any:
    """A damping as the native module takes it: a dict of one of the job file's forms, which
    the library reads and builds as the job file's ``[model] damping``, or a matrix
    (``_matrix``: numpy, scipy.sparse or nested lists) for ``C=``, a bare matrix and
    ``{"matrix": C}``."""
    if isinstance(damping, dict):
        if set(damping) == {"matrix"}:
            return _matrix("damping", damping["matrix"])
        return {
            k: os.fspath(v) if isinstance(v, os.PathLike) else
            [_checks.real(f"damping {k}", x) for x in v] if isinstance(v, (list, tuple, np.ndarray)) else v
            for k, v in damping.items()
        }
    return _matrix("damping", damping)


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


def modes(model: Model) -> Modes:
    """Linear modes of ``model`` in ascending frequency, as ``nnm modes`` lists them (all of
    them; the 20 lowest for sparse models above 2,000 dofs). Every mode is checked against
    ``K`` and ``M`` as given (docs/method.md §10)."""
    raw = model._native.modes()
    labels = [_parse_label(s) for s in raw["label"]]
    return Modes(raw["frequency"], raw["shapes"], raw["rigid"], labels, raw["pattern"])


def backbone(
    model: Model,
    mode: int | str | tuple[int, int] | None = None,
    *,
    pattern: str | None = None,
    energy_max: float | None = None,
    frequency_shift_max: float | None = None,
    max_points: int | None = None,
    branch: str | None = None,
    progress: bool | None = None,
    callback: Callable[[int, float, float, bool], Any] | None = None,
    raise_on_failure: bool = True,
    **settings: Any,
) -> Branch:
    """Follows the NNM branch that starts from a linear mode of ``model``.

    ``mode`` is an index into :func:`nnm.modes` (ascending frequency), or on cyclic models a
    label ``(n, d)`` or ``"n,d"`` (``pattern="sin"`` for the other standing wave of a pair,
    ``"travelling"`` / ``"travelling-backward"`` for its travelling waves, docs/method.md §17).
    The branch stops at ``energy_max``, at ``frequency_shift_max`` (``|ω/ω0 - 1|``; the last
    point lies on either limit to 1e-10) or after ``max_points``; at least one is required.
    Other keywords are the job file's settings with the same names, meanings and defaults
    (``tolerance``, ``initial_step``, ``min_step``, ``max_step``, ``max_iterations``,
    ``target_iterations``, ``max_turn_angle``, ``energy_start``, ``symmetry``, ``phase``,
    ``jacobian``, ``half_period``, ``integrator``, ``integration_factor``,
    ``stability_tolerance``, ``events``, ``invariant_step``, and ``at_energies`` / ``at_frequencies``: lists of
    values (rad/s for frequencies) that get points exactly on them, ``label`` says which;
    docs/job-files.md "Settings"). ``resonance_force`` (an :class:`nnm.Force` or its dict, e.g.
    ``{"dofs": [0]}``; an amplitude is not needed) asks every point for the force amplitude
    whose resonance peak it is, by energy balance with the model's damping (``Model(...,
    damping=...)``, required): ``Branch.resonance_force`` and ``resonance_phase``
    (docs/method.md §21). ``branch=NAME`` instead runs a ``[[branch]]`` of the job file the
    model came from, with its settings (from ``mode`` instead of the branch's own when both
    are given: what a sweep does on a mistuned disk).

    The computation runs without the GIL. Ctrl-C stops it between points, raising
    ``KeyboardInterrupt`` whose ``branch`` attribute holds the points computed so far (as does
    an exception raised by the callback); ``callback(index, energy, frequency, stable)`` is called after
    each point and stops the branch by returning ``False``; with tqdm installed a progress
    bar shows once a run takes more than a second (``progress=True``: at once, ``False``:
    never).

    Raises ``ValueError``/``TypeError`` for bad input (an unknown mode or setting, a value out
    of range), with the message ``nnm run`` gives. A branch that cannot be followed to its
    limit (the first point does not converge, or a step fails at the minimum step size)
    raises :class:`nnm.ContinuationError` with the points computed so far on its ``branch``;
    with ``raise_on_failure=False`` that branch is returned instead (see ``Branch.stop``).
    """
    if not isinstance(model, Model):
        raise TypeError(f"model must be an nnm.Model, got {type(model).__name__}")
    if mode is None and branch is None:
        raise TypeError('backbone() needs `mode` (an index, (n, d) or "n,d") or `branch` (a job file\'s)')
    for key in ("name", "start"):
        if key in settings:
            raise TypeError(f"backbone() got an unexpected keyword argument '{key}'")
    if isinstance(settings.get("resonance_force"), Force):
        settings["resonance_force"] = settings["resonance_force"].to_dict()
    if settings.get("resonance_force") is not None and model._damping is None:
        raise ValueError(
            "resonance_force needs the model's damping: the energy balance weighs the force's work against "
            "what damping dissipates (nnm.Model(..., damping=...) or model.with_damping(...))"
        )
    options = _options(energy_max, frequency_shift_max, max_points, settings)
    if pattern is not None:
        options["pattern"] = pattern
    if isinstance(mode, tuple):
        mode = _label(mode)
    described = branch if branch is not None else mode

    def call(observe: Any) -> dict[str, Any]:
        return model._native.backbone(mode, options, branch, observe, model._damping)

    return _follow(model, call, f"mode {described}", progress, callback, raise_on_failure)


# The built-in families: the job file's `family = "..."` with its keys as keyword arguments, and
# the defaults the library declares for them (tests/test_inputs.py builds each both ways).


def _built_in_family(name: str) -> Callable[[Callable[..., dict[str, Any]]], Callable[..., Model]]:
    """The constructor of the built-in family ``name``: its keyword parameters and their
    defaults are the library's (``_nnm.family_defaults``, the defaults a job file naming only
    the family gets), declared once in the core's family struct; the decorated function's
    docstring documents them and its body prepares the given values for the library."""

    def constructor(prepare: Callable[..., dict[str, Any]]) -> Callable[..., Model]:
        defaults = _nnm.family_defaults(name)
        parameters = [
            inspect.Parameter(key, inspect.Parameter.KEYWORD_ONLY, default=value,
                              annotation=type(value).__name__)
            for key, value in defaults.items()
        ]
        if "damping" not in defaults:
            # Every family takes a damping (the job file's `[model] damping`), kept beside it.
            parameters.append(inspect.Parameter("damping", inspect.Parameter.KEYWORD_ONLY, default=None,
                                                annotation="Any"))
        signature = inspect.Signature(parameters, return_annotation="Model")

        @functools.wraps(prepare)
        def build(*args: Any, **parameters: Any) -> Model:
            # A TypeError for a positional or unknown argument, as a plain signature gives.
            given = signature.bind(*args, **parameters).arguments
            damping = given.pop("damping", None)
            model = Model._family(name, prepare(**given))
            if damping is not None:
                model._set_damping(damping)
            return model

        build.__signature__ = signature  # type: ignore[attr-defined]
        return build

    return constructor


@_built_in_family("bladed-disk")
def bladed_disk(**parameters: Any) -> dict[str, Any]:
    """The paper's bladed disk (docs/method.md §11): ``sectors`` sectors of a disk mass
    ``disk_mass`` (M) and a blade mass ``blade_mass`` (m), disks coupled by ``disk_coupling``
    (K), each blade on its disk by a linear spring ``blade_stiffness`` (k) and a cubic one
    ``cubic`` (knl). Dof ``2i`` is the disk of sector ``i``, ``2i + 1`` its blade; cyclic, so
    modes are labelled ``(n, d)`` (Table 1 of the paper with the defaults).

    ``blade_stiffness_mistuning`` (one relative deviation ``δ_i > -1`` per sector, any
    sequence) mistunes the blades, ``k_i = k (1 + δ_i)``; a mistuned disk is not cyclic (its
    modes are unlabelled, its pairs split)."""
    mistuning = parameters.get("blade_stiffness_mistuning")
    if mistuning is not None:
        parameters["blade_stiffness_mistuning"] = [_checks.real("blade_stiffness_mistuning", d) for d in mistuning]
    return parameters


@_built_in_family("duffing")
def duffing(**parameters: Any) -> dict[str, Any]:
    """The Duffing oscillator ``x'' + w0^2 x + a x^3 = 0`` (``w0 = natural_frequency``,
    ``a = cubic``), whose backbone has an exact elliptic period."""
    return parameters


@_built_in_family("two-dof")
def two_dof(**parameters: Any) -> dict[str, Any]:
    """The two-DOF system of Kerschen et al. (2009): ``x1'' + (2 x1 - x2) + c x1^3 = 0``,
    ``x2'' + (2 x2 - x1) = 0`` with ``c = cubic``."""
    return parameters


@_built_in_family("cantilever-beam")
def cantilever_beam(**parameters: Any) -> dict[str, Any]:
    """The ECL cantilever beam of NLvib's example 09: Euler–Bernoulli finite elements
    (deflection and rotation per node, consistent mass), clamped at one end, a cubic spring
    ``cubic`` (N/m^3) from the tip to ground. SI units."""
    return parameters


@_built_in_family("solid")
def solid(**parameters: Any) -> dict[str, Any]:
    """A St. Venant–Kirchhoff box ``[0, Lx] × [0, Ly] × [0, Lz]`` (``box``) of triquadratic
    27-node hexahedra (``element = "hex27"``), ``elements`` along each edge, the faces named in
    ``clamped`` (``"x0"``, ``"x1"``, ``"y0"``, ... or a list) held; nonlinear force and tangent
    computed element by element (docs/method.md §20). Node ``i + (2nx+1)(j + (2ny+1)k)`` has
    dofs ``3·node + c``, the clamped nodes' removed (docs/job-files.md, "Solids"). SI units.

    Or a Gmsh mesh: ``mesh="blade.msh"`` (MSH 4.1, 10-node tetrahedra and 27-node hexahedra)
    with ``clamped`` naming its physical groups (docs/job-files.md, "Meshes")."""
    mesh = parameters.get("mesh")
    if mesh is not None and not isinstance(mesh, dict):
        parameters["mesh"] = {"file": os.fspath(mesh)}
    for key in ("box", "elements"):
        if key in parameters and not isinstance(parameters[key], str):
            parameters[key] = list(parameters[key])
    clamped = parameters.get("clamped")
    if clamped is not None and not isinstance(clamped, str):
        parameters["clamped"] = list(clamped)
    return parameters


@_built_in_family("von-karman-beam")
def von_karman_beam(**parameters: Any) -> dict[str, Any]:
    """A clamped-clamped von Kármán beam: axial and transverse dofs per node, with the exact
    quadratic and cubic forces of the membrane stretch. SI units."""
    return parameters
