"""A computed branch of nonlinear normal modes (:class:`Branch`, its :class:`Event` and
:class:`Motion`), how a native continuation becomes one, and switching at its events.
:func:`nnm.backbone` (with the models, in ``_model``) starts a branch from a linear mode."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, NamedTuple

import numpy as np

from . import _checks, _nnm
from ._errors import ContinuationError
from ._labels import _parse_label

if TYPE_CHECKING:
    import matplotlib.axes
    import pandas

    from ._model import Model


@dataclass(frozen=True)
class Event:
    """A bifurcation located between two points of a branch (the rows of
    ``<branch>.events.csv``).

    ``kind`` is ``"fold"``, ``"branch-point"``, ``"period-doubling"`` or ``"neimark-sacker"``
    (``abbreviation`` F, BP, PD, NS); ``multiplier`` the critical Floquet multiplier,
    ``multiplicity`` how many pairs are critical at once; ``after_point`` the branch point it
    follows; ``converged`` is False for an event placed only to ``arclength_uncertainty``.
    ``state0`` is its initial state ``[x0; v0]``.
    """

    kind: str
    abbreviation: str
    energy: float
    frequency: float
    period: float
    multiplier: complex
    multiplicity: int
    after_point: int
    arclength_uncertainty: float
    converged: bool
    # Left out of the repr: a list of events would print every state in full.
    state0: np.ndarray = field(repr=False)


class Motion(NamedTuple):
    """One period of a point's motion: times ``t`` (``samples + 1``, the last closing the
    orbit), displacements ``x`` and velocities ``v`` (``len(t) × n``)."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray


class PointColumn(NamedTuple):
    """A column of a branch's (or a response's) points as the library declares it, once for
    the CSV file and the :class:`Branch` (crates/nnm-io/src/output/columns.rs; a
    :class:`nnm.Response`'s in crates/nnm-io/src/output/response.rs): ``key`` is the array,
    ``name`` the CSV header (``<d>`` standing for the output dof when ``per_output_dof``: one
    field each, the array points × len(``output_dofs``)), ``kind`` ``"float"``, ``"integer"``,
    ``"optional-integer"`` (float, NaN where a point has none), ``"bool"`` or ``"text"``, and
    ``csv`` whether the CSV file (and ``to_pandas()``) has it."""

    key: str
    name: str
    unit: str
    doc: str
    kind: str
    csv: bool
    per_output_dof: bool


# A Branch's point columns, in the order `<branch>.csv` has them.
_POINT_COLUMNS = [PointColumn(*c) for c in _nnm.POINT_COLUMNS]


class Branch:
    """A computed branch: one entry per converged point, in continuation order.

    Arrays (numpy, one entry per point): ``energy`` (total energy of the motion),
    ``frequency`` (rad/s), ``frequency_hz`` (``frequency / 2π``: Hz when the model's time unit
    is the second), ``frequency_ratio`` (``frequency / linear_frequency``: ``ω/ω0``), ``period``
    (s), ``state0`` (points × 2n: the initial state
    ``[x0; v0]`` of each periodic motion), ``stable``, ``multipliers`` (points × 2n complex
    Floquet multipliers, the two trivial ones at +1 last), ``max_floquet_modulus``,
    ``unstable_pairs``, ``relative_residual``, ``full_period_residual``, ``iterations``,
    ``step``, ``energy_slope``, ``label`` (``""`` for a continuation step; ``"at_energy"`` or
    ``"at_frequency"`` for a point placed exactly on a requested value, ``"energy_max"`` or
    ``"frequency_shift_max"`` for the last point, on the limit), ``peak_displacement``
    (points × len(``output_dofs``): the largest ``|x_d(t)|`` over the period of each output dof),
    ``regime`` (``"backbone"``, ``"tongue"`` or ``"other-family"``: where the point is relative to
    the branch's first, with the resonant ``partner_mode``, its ``partner_harmonic``,
    ``partner_share`` of the energy — NaN without one — and the ``ratio`` ``"m:n"``; see
    docs/output.md). Also ``missed_requests``
    (requested values without a point: dicts of ``label``, ``value`` and ``why``), ``events`` (list of :class:`Event`), ``stop`` (why it
    ended, in words) and ``stop_kind`` (``"energy-max"``, ``"frequency-shift-max"``,
    ``"max-points"``, ``"callback"``, ``"interrupted"``, ``"step-too-small"`` or
    ``"first-point"``), ``linear_frequency`` (of the starting mode), the starting ``mode``
    (index), ``mode_label`` and ``pattern``, work counters in ``stats``, and ``wall_time``,
    the seconds the continuation took in the library (the rest of a call's time is modal
    analysis and the bindings' own). A branch from :meth:`switch` has ``switched_from``
    (``event``, ``direction``, ``kind`` and the ``phase`` condition it was computed with).

    The per-point arrays are the library's point columns (:class:`PointColumn`), listed with
    their units at the end of this text.
    """

    # The annotations are for type checkers, which cannot read the library's list; a test holds
    # the arrays among them to the declared columns.

    energy: np.ndarray
    frequency: np.ndarray
    frequency_hz: np.ndarray
    frequency_ratio: np.ndarray
    period: np.ndarray
    state0: np.ndarray
    stable: np.ndarray
    multipliers: np.ndarray
    max_floquet_modulus: np.ndarray
    unstable_pairs: np.ndarray
    relative_residual: np.ndarray
    full_period_residual: np.ndarray
    reciprocity_defect: np.ndarray
    iterations: np.ndarray
    step: np.ndarray
    energy_slope: np.ndarray
    index: np.ndarray
    label: np.ndarray
    output_dofs: list[int]
    peak_displacement: np.ndarray
    regime: np.ndarray
    partner_mode: np.ndarray
    partner_harmonic: np.ndarray
    partner_share: np.ndarray
    ratio: np.ndarray
    resonance_force: np.ndarray
    resonance_phase: np.ndarray
    missed_requests: list[dict[str, Any]]
    events: list[Event]
    stop: str
    stop_kind: str
    linear_frequency: float
    mode: int
    mode_label: tuple[int, int] | None
    pattern: str | None
    stats: dict[str, int]
    wall_time: float
    switched_from: dict[str, Any] | None
    model: Model | None

    def __init__(self, model: Model, raw: dict[str, Any], parent: "Branch | None" = None) -> None:
        self.model = model
        events = raw.pop("events")
        self._native = raw.pop("native")
        if parent is None:
            self.mode = raw.pop("mode_index")
            self.mode_label = _parse_label(raw.pop("mode_label"))
            self.switched_from = None
        else:  # a switched branch belongs to its parent's mode family
            self.mode, self.mode_label, self.pattern = parent.mode, parent.mode_label, parent.pattern
        raw.pop("error", None)
        for key, value in raw.items():
            setattr(self, key, value)
        n = model.dofs
        if self.state0.shape[0] == 0:
            self.state0 = self.state0.reshape(0, 2 * n)
        for column in _POINT_COLUMNS:
            if column.kind == "text":  # a list of str from the library
                setattr(self, column.key, np.array(getattr(self, column.key), dtype=object))
        self.events = [Event(**e) for e in events]

    def __len__(self) -> int:
        return len(self.energy)

    def __getstate__(self) -> dict[str, Any]:
        # The model lives in the library and does not pickle: a branch sent to another process
        # (a process pool, a Dask worker's result) keeps its arrays but not `motion()`.
        state = dict(self.__dict__)
        state["model"] = None
        state["_native"] = None
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)

    def __repr__(self) -> str:
        mode = self.mode if self.mode_label is None else self.mode_label
        return f"<nnm.Branch of mode {mode}: {len(self)} points, {len(self.events)} events, {self.stop}>"

    @property
    def frequency_shift(self) -> np.ndarray:
        """``frequency / linear_frequency - 1`` per point."""
        return self.frequency / self.linear_frequency - 1.0

    @property
    def displacement0(self) -> np.ndarray:
        """The initial displacements ``x0`` (points × n): the NNM's deflected shape at rest."""
        return self.state0[:, : self.state0.shape[1] // 2]

    def motion(self, i: int, samples: int = 100, tolerance: float = 1e-10) -> Motion:
        """The motion of point ``i`` over one period, at ``samples + 1`` equal times, to
        relative ``tolerance``: each segment integrated adaptively (so sampling costs no
        accuracy), or, for a stiff model (a finite-element beam or solid), by the collocation
        method its branches use, on as many equal steps as its global error estimate over the
        period asks, rounded up to a multiple of ``samples``.

        ``i`` counts as the per-point arrays do (``-1`` is the last point, as in
        ``branch.energy[-1]``); ``samples`` is at least 1 and at most what fits in half the
        machine's memory; ``tolerance`` is in the range a job file's ``tolerance`` takes. Any
        other value raises ``ValueError`` (``TypeError`` for a value of the wrong type)
        before anything is computed."""
        # Python-style indices: the point `motion(i)` shows is the one `energy[i]` describes.
        n = len(self)
        points = f"{n} point{'' if n == 1 else 's'} (0 to {n - 1}, or -{n} to -1 from the end)" if n else "no points"
        i = _checks.index("the point index", i, n, f"point {{}} does not exist: the branch has {points}")
        if self.model is None:
            raise ValueError("this branch was unpickled without its model: motion() needs the model")
        samples = _checks.samples(samples, self.model.dofs)
        tolerance = _checks.real("tolerance", tolerance)
        z = self.model._native.motion(self.state0[i], float(self.period[i]), samples, tolerance)
        n = self.model.dofs
        t = np.linspace(0.0, self.period[i], z.shape[0])
        return Motion(t, z[:, :n], z[:, n:])

    def to_vtk(self, i: int, path: str | os.PathLike, frames: int = 32) -> None:
        """ParaView files of point ``i``'s motion over one period in ``frames`` frames:
        ``path`` (a ``.pvd`` collection whose time steps are the frames' times) and the
        frames ``frame-NNN.vtu`` in the folder of that name without ``.pvd``, each with the
        point data ``displacement`` (in ParaView: open the ``.pvd``, then "Warp By Vector").

        For models whose dofs sit on nodes (the beam and solid families). ``i`` counts as
        :meth:`motion`'s does. A model without nodes, a bad index, ``frames`` below 1 or a
        ``path`` not ending in ``.pvd`` raise ``ValueError`` before anything is computed or
        written; a file that cannot be written, ``OSError``."""
        if self.model is None:
            raise ValueError("this branch was unpickled without its model: to_vtk() needs the model")
        if not self.model._native.has_layout:
            raise ValueError(
                "to_vtk draws on a model's nodes: the beam and solid families have them, this model does not"
            )
        path = os.fspath(path)
        if not str(path).endswith(".pvd"):
            raise ValueError(f"to_vtk writes a ParaView collection: the path must end in .pvd, got {path!r}")
        frames = _checks.integer("frames", frames)
        if frames < 1:
            raise ValueError(f"frames must be at least 1, got {frames}")
        n = len(self)
        points = f"{n} point{'' if n == 1 else 's'} (0 to {n - 1}, or -{n} to -1 from the end)" if n else "no points"
        _checks.index("the point index", i, n, f"point {{}} does not exist: the branch has {points}")
        motion = self.motion(i, samples=frames, tolerance=1e-8)
        self.model._native.write_vtk(path, [float(t) for t in motion.t[:-1]], np.ascontiguousarray(motion.x[:-1]))

    def switch(self, event: int = 0, **kwargs: Any) -> "Branch":
        """The family through ``events[event]`` (see :func:`nnm.switch`)."""
        return switch(self, event, **kwargs)

    def to_pandas(self) -> "pandas.DataFrame":
        """The points as a DataFrame with the columns of ``<branch>.csv``."""
        return _csv_frame(self, _POINT_COLUMNS)

    def plot(self, ax: "matplotlib.axes.Axes | None" = None, **kwargs: Any) -> "matplotlib.axes.Axes":
        """The frequency–energy plot of this branch (see :func:`nnm.plot.fep`)."""
        from . import plot

        return plot.fep([self], ax=ax, **kwargs)


def _csv_frame(points: Any, columns: list[PointColumn]) -> "pandas.DataFrame":
    """The arrays of ``points`` (a Branch, a Response) that the CSV file has, as its columns:
    one per output dof for a column with a field each."""
    import pandas

    frame = {}
    for column in columns:
        if not column.csv:
            continue
        values = getattr(points, column.key)
        if column.per_output_dof:
            for k, dof in enumerate(points.output_dofs):
                frame[column.name.replace("<d>", str(dof))] = values[:, k]
        else:
            frame[column.name] = values
    return pandas.DataFrame(frame)


def _columns_doc(columns: list[PointColumn]) -> str:
    """The columns listed for a class's docstring."""
    return "".join(f"    - ``{c.key}`` ({c.unit}): {c.doc}\n" for c in columns)


Branch.__doc__ = (Branch.__doc__ or "") + "\n    Point columns (array, unit: meaning):\n\n" + _columns_doc(_POINT_COLUMNS)


def _options(
    energy_max: float | None, frequency_shift_max: float | None, max_points: int | None, settings: dict[str, Any]
) -> dict[str, Any]:
    """The job-file keys of a branch: its stop limits (those given) and other settings."""
    limits = {"energy_max": energy_max, "frequency_shift_max": frequency_shift_max, "max_points": max_points}
    return {**{k: v for k, v in limits.items() if v is not None}, **settings}


def _tqdm_callback(show: bool | None, description: str) -> tuple[Callable[..., Any] | None, Any]:
    """A progress callback on a tqdm bar, and the bar (to close), when tqdm is installed and
    ``show`` is not False. With ``show=None`` the bar appears only once the run has taken a
    second, so that short runs print nothing."""
    if show is False:
        return None, None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        if show:
            raise
        return None, None
    bar = tqdm(desc=description, unit=" points", delay=0.0 if show else 1.0, leave=bool(show))

    def update(index: int, energy: float, frequency: float, stable: bool) -> None:
        bar.set_postfix_str(f"E = {energy:.4g}, f = {frequency:.6g} rad/s", refresh=False)
        bar.update(1)

    return update, bar


def _follow(
    model: Model,
    call: Callable[[Any], dict[str, Any]],
    description: str,
    progress: bool | None,
    callback: Callable[[int, float, float, bool], Any] | None,
    raise_on_failure: bool,
    parent: Branch | None = None,
) -> Branch:
    """Runs ``call(observe)`` (a native continuation) with the progress bar and the user's
    callback on every point, and makes its result a :class:`Branch`, raising
    :class:`ContinuationError` for a failure unless ``raise_on_failure`` is False."""
    update, bar = _tqdm_callback(progress, description)

    def observe(index: int, energy: float, frequency: float, stable: bool) -> Any:
        if update is not None:
            update(index, energy, frequency, stable)
        if callback is not None:
            return callback(index, energy, frequency, stable)
        return None

    try:
        raw = call(observe if (update is not None or callback is not None) else None)
    except BaseException as error:
        # Ctrl-C (KeyboardInterrupt) or the callback's exception: its `branch` holds the
        # points computed before it.
        partial = error.__dict__.pop("partial", None)
        if isinstance(partial, dict):
            error.branch = Branch(model, partial, parent)
        raise
    finally:
        if bar is not None:
            bar.close()
    error = raw.get("error")
    result = Branch(model, raw, parent)
    if error is not None and raise_on_failure:
        raise ContinuationError(error, result)
    return result


def switch(
    branch: Branch,
    event: int = 0,
    *,
    direction: int = 0,
    energy_max: float | None = None,
    frequency_shift_max: float | None = None,
    max_points: int | None = None,
    progress: bool | None = None,
    callback: Callable[[int, float, float, bool], Any] | None = None,
    raise_on_failure: bool = True,
    **settings: Any,
) -> Branch:
    """Follows the other family through ``branch.events[event]``: at a ``branch-point`` the
    family crossing this one, at a ``period-doubling`` the family of twice the period
    (docs/method.md §9), as a job file's ``start = { branch = ..., event = ... }`` does.

    The new branch starts 5% of the event's amplitude away along the new null direction
    (``direction`` picks one at a degenerate event, ``multiplicity > 1``), with every elastic
    mode an unknown and the full period shot; its stop limits and other settings are keywords
    as for :func:`backbone` (``energy_start``, ``symmetry``, ``half_period`` and ``pattern`` do
    not apply). Its ``switched_from`` says which event and phase condition it came from.

    ``event`` counts as ``branch.events`` does (``-1`` is the last event). Raises
    ``ValueError`` for an event the branch does not have or a negative ``direction``
    (``TypeError`` for one that is not an integer), at a fold or
    Krein collision (no other family crosses there) or for bad settings,
    :class:`nnm.NumericalError` when no new null direction is found, and
    :class:`nnm.ContinuationError` as :func:`backbone` does.
    """
    if not isinstance(branch, Branch):
        raise TypeError(f"branch must be an nnm.Branch, got {type(branch).__name__}")
    if branch.model is None or branch._native is None:
        raise ValueError("this branch was unpickled without its model: switching needs the original")
    count = len(branch.events)
    event = _checks.index(
        "event", event, count, f"the branch has {count} event{'' if count == 1 else 's'}, so no event {{}}"
    )
    direction = _checks.integer("direction", direction)
    if direction < 0:
        raise ValueError(f"direction must be 0 or more, got {direction}")
    options = _options(energy_max, frequency_shift_max, max_points, settings)
    model = branch.model

    def call(observe: Any) -> dict[str, Any]:
        return model._native.switch(branch._native, event, direction, options, observe)

    description = f"switch at event {event}"
    return _follow(model, call, description, progress, callback, raise_on_failure, parent=branch)
