"""The force shape of forced responses and of a backbone's ``resonance_force``: the job
file's ``force = { ... }`` forms, read by the library's own parser (``nnm_io::job``) so that a
script and a job file are refused for the same reasons."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from . import _checks, _nnm


class Force:
    """A harmonic force, as the job file's ``force = { ... }`` gives it:

    - ``Force(dofs=[i, j], amplitude=a)``: ``a cos Ωt`` on each of the dofs (an int for one);
    - ``Force(vector=[...])``: ``F cos Ωt`` with ``F`` one entry a dof (its size is its own:
      the curve's force amplitude is 1, and ``amplitudes=`` levels multiply it);
    - ``Force(engine_order=k, amplitude=a, sector_dof=j)``: on a cyclic model, dof ``j`` of
      sector ``s`` driven by ``a cos(Ωt − 2πks/N)`` (a wave travelling ``k`` sectors a
      revolution; sector-major numbering), ``0 ≤ k ≤ N/2``.

    Dofs are 0-based. Forced ``dofs`` and a ``vector`` are in the model's full numbering, the
    numbering of ``M`` and ``K`` before ``fixed_dofs`` (as the dofs of nonlinear springs and a
    damping matrix are, and as a job file's ``force`` is): a vector has one entry per dof of
    ``M``. An engine order's ``sector_dof``, like ``output_dofs`` and the response's
    ``output_dofs`` and ``phase_dof``, is in the numbering of the model computed (after
    ``fixed_dofs``, ``model.dofs`` of them). Dofs out of range, a forced dof that is fixed (or a
    vector's non-zero entry on one: a support takes that force), an engine order on a
    non-cyclic model and a vector of the wrong length are refused when a response is computed
    (they depend on the model), with the job file's messages (the conversion is the job
    file's own function)."""

    def __init__(
        self,
        dofs: int | Sequence[int] | None = None,
        amplitude: float | None = None,
        *,
        vector: Any = None,
        engine_order: int | None = None,
        sector_dof: int | None = None,
    ) -> None:
        spec: dict[str, Any]
        if vector is not None:
            if dofs is not None or amplitude is not None or engine_order is not None or sector_dof is not None:
                raise TypeError("Force(vector=...) takes nothing else: the vector carries its own size")
            values = np.asarray(vector)
            if _checks.holds_bool(vector):  # [True, 0.5] reads as float64
                raise TypeError("the force vector must be a 1-D sequence of real numbers, got bool")
            if values.dtype.kind not in "iuf" or values.ndim != 1:
                raise TypeError(f"the force vector must be a 1-D sequence of real numbers, got {values.dtype} of shape {values.shape}")
            spec = {"vector": [float(v) for v in values]}
        elif engine_order is not None:
            if dofs is not None:
                raise TypeError("Force(engine_order=...) forces `sector_dof` of every sector: no `dofs`")
            if amplitude is None or sector_dof is None:
                raise TypeError("Force(engine_order=k) needs `amplitude` and `sector_dof` too")
            spec = {
                "engine_order": _nonnegative("engine_order", engine_order),
                "amplitude": _checks.real("amplitude", amplitude),
                "sector_dof": _nonnegative("sector_dof", sector_dof),
            }
        elif dofs is not None:
            if sector_dof is not None:
                raise TypeError("`sector_dof` goes with `engine_order`, not with `dofs`")
            if amplitude is None:
                raise TypeError("Force(dofs=...) needs `amplitude`")
            dof_list = [dofs] if hasattr(type(dofs), "__index__") and not isinstance(dofs, bool) else list(dofs)
            spec = {
                "dofs": [_nonnegative("forced dof", d) for d in dof_list],
                "amplitude": _checks.real("amplitude", amplitude),
            }
        else:
            raise TypeError("Force needs `dofs` and `amplitude`, `vector`, or `engine_order`, `amplitude` and `sector_dof`")
        # Read by the library's own parser now: the forms are declared once, there.
        _nnm.force_amplitude(spec)
        self._spec = spec

    @classmethod
    def _of(cls, force: "Force | dict[str, Any]") -> "Force":
        if isinstance(force, Force):
            return force
        if isinstance(force, dict):
            return cls(**force)
        raise TypeError(f"force must be an nnm.Force or a dict of its keys, got {type(force).__name__}")

    @property
    def amplitude(self) -> float:
        """The force amplitude ``a`` (1 for a vector)."""
        return float(self._spec.get("amplitude", 1.0))

    def to_dict(self) -> dict[str, Any]:
        """The job file's keys of this force."""
        return dict(self._spec)

    def __repr__(self) -> str:
        return "nnm.Force(" + ", ".join(f"{k}={v!r}" for k, v in self._spec.items()) + ")"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Force) and other._spec == self._spec


def _nonnegative(name: str, value: Any) -> int:
    i = _checks.integer(name, value)
    if i < 0:
        raise ValueError(f"{name} must be 0 or more (0-based), got {i}")
    return i
