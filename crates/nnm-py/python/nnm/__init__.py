"""nnm — nonlinear normal modes of structures ``M x'' + K x + f_nl(x) = 0``.

Branches of periodic motions started from the linear modes and followed in energy by
shooting and pseudo-arclength continuation, with Floquet stability and located bifurcations
(the Rust library ``nnm``; docs/method.md numbers the equations).

>>> import nnm
>>> model = nnm.duffing(natural_frequency=1.0, cubic=1.0)
>>> branch = nnm.backbone(model, mode=0, frequency_shift_max=0.5)
>>> round(float(branch.frequency[-1]), 9)
1.5

Models: :class:`Model` (``M``, ``K`` as numpy or scipy.sparse, with :class:`Cubic`,
:class:`Polynomial`, :class:`Tensor` elements), :meth:`Model.from_job`, and the families
:func:`bladed_disk`, :func:`duffing`, :func:`two_dof`, :func:`cantilever_beam`,
:func:`von_karman_beam`, :func:`solid` (checkable against one's own code through
:meth:`Model.internal_force` and :meth:`Model.tangent_stiffness`). Analyses: :func:`modes`, :func:`backbone` (a :class:`Branch`),
:func:`switch` (the family through a branch point or period doubling of a branch).
Forced, damped responses: :func:`frequency_response` and :func:`force_response` (a
:class:`Response`) of a model with damping (``Model(..., damping=...)``) driven by a
:class:`Force`.
Sweeps over mistuned or varied models on Dask: :func:`sweep` (:mod:`nnm.sweeps`; on the
command line ``python -m nnm sweep``).
Figures: :mod:`nnm.plot`. Errors: ``ValueError``/``TypeError`` for bad input,
:class:`ContinuationError` (a :class:`NumericalError`) for a branch that failed, with its
points so far.
"""

from types import MappingProxyType

from ._branch import Branch, Event, Motion, switch
from ._elements import Cubic, Polynomial, Tensor
from ._errors import ContinuationError, NumericalError
from ._model import (
    Model,
    Modes,
    backbone,
    bladed_disk,
    cantilever_beam,
    duffing,
    modes,
    solid,
    two_dof,
    von_karman_beam,
)
from ._nnm import RESPONSE_SETTINGS_KEYS, SETTINGS_KEYS, __version__
from ._nnm import RESPONSE_DEFAULTS as _RESPONSE_DEFAULTS
from ._response import Force, Response, ResponseEvent, Responses, force_response, frequency_response, job_response
from .sweeps import sweep

#: A forced response's default settings (read-only: the library's, which a curve runs with).
RESPONSE_DEFAULTS = MappingProxyType(_RESPONSE_DEFAULTS)

__all__ = [
    "Branch",
    "ContinuationError",
    "Cubic",
    "Event",
    "Force",
    "Model",
    "Modes",
    "Motion",
    "NumericalError",
    "Polynomial",
    "RESPONSE_DEFAULTS",
    "RESPONSE_SETTINGS_KEYS",
    "Response",
    "ResponseEvent",
    "Responses",
    "SETTINGS_KEYS",
    "Tensor",
    "__version__",
    "backbone",
    "bladed_disk",
    "cantilever_beam",
    "duffing",
    "force_response",
    "frequency_response",
    "job_response",
    "modes",
    "solid",
    "sweep",
    "switch",
    "two_dof",
    "von_karman_beam",
]
