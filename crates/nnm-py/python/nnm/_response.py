"""Forced, damped responses: ``M x'' + C x' + f_int(x) = a (F_c cos Ωt + F_s sin Ωt)``.

:class:`Force` (in ``_force``) mirrors the job file's ``force = { ... }`` keys, :func:`frequency_response`
and :func:`force_response` compute a curve (a :class:`Response`) by shooting over the
forcing period and pseudo-arclength continuation through folds (docs/method.md §19). The
forms a force and a damping may take, their numbering, checks and messages are the
library's (the job file's own functions, ``nnm_io::job``): a script and a job file number a
forced dof alike (before ``fixed_dofs``, as springs' dofs) and are refused for the same
reasons.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Sequence

import numpy as np

from . import _checks, _nnm
from ._branch import Motion, PointColumn, _columns_doc, _csv_frame
from ._errors import ContinuationError
from ._force import Force, _nonnegative

if TYPE_CHECKING:
    import matplotlib.axes
    import pandas

    from ._model import Model


@dataclass(frozen=True)
class ResponseEvent:
    """A fold or bifurcation located on a response curve (the rows of
    ``<name>.events.csv``): ``kind`` ``"fold"`` (a turning point in the continued parameter:
    where a sweep jumps), ``"neimark-sacker"``, ``"period-doubling"``, ``"branch-point"`` or
    ``"phase-resonance"`` (the first harmonic lags the force by π/2, docs/method.md eq. (113));
    its ``frequency`` (rad/s), ``force_amplitude``, ``peaks`` (one per output dof),
    ``harmonic_amplitude`` and ``phase_lag`` of the first harmonic, ``critical_multiplier``
    (for a fold the real one nearest +1), ``after_point`` (the curve point it follows) and
    ``state0``."""

    kind: str
    frequency: float
    force_amplitude: float
    peaks: np.ndarray
    harmonic_amplitude: float
    phase_lag: float
    critical_multiplier: complex
    after_point: int
    state0: np.ndarray = field(repr=False)

    @property
    def peak(self) -> float:
        """The peak of the first output dof."""
        return float(self.peaks[0]) if len(self.peaks) else float("nan")


# A Response's point columns, in the order `<response>.csv` has them.
_RESPONSE_COLUMNS = [PointColumn(*c) for c in _nnm.RESPONSE_COLUMNS]


class Response:
    """A forced response curve: one entry per converged point, in continuation order (the
    curve may run backwards in the parameter between folds).

    Arrays (numpy, one entry per point): the library's response columns, listed with their
    units at the end of this text (``frequency`` in rad/s, ``peaks`` points ×
    len(``output_dofs``), ``harmonic_amplitude`` and ``phase_lag`` of the first harmonic
    ``A cos(Ωt − φ)`` of ``phase_dof``, the first forced dof, ``curve`` the force level's
    place among ``amplitudes``), and ``multipliers`` (points × 2n complex, by decreasing
    modulus) and ``state0`` (points × 2n: ``[x; v]`` at ``t = 0``, where the force's phase
    is 0). Also ``events`` (list of :class:`ResponseEvent`), ``parameter``
    (``"frequency"`` or ``"amplitude"``: what was continued), ``force`` (the
    :class:`Force`, at the curve's amplitude), ``stop`` (why it ended, in words),
    ``stop_kind`` (``"end"``, ``"start"``, ``"max-points"``, ``"closed"`` (back onto
    itself: an isolated loop), ``"callback"``, ``"interrupted"``, ``"failed"`` or
    ``"first-point"``), ``integrator``, ``stats`` and ``wall_time``.
    """

    # The annotations are for type checkers, which cannot read the library's list; a test holds
    # the arrays among them to the declared columns.

    curve: np.ndarray
    index: np.ndarray
    frequency: np.ndarray
    frequency_hz: np.ndarray
    force_amplitude: np.ndarray
    peaks: np.ndarray
    harmonic_amplitude: np.ndarray
    phase_lag: np.ndarray
    stable: np.ndarray
    max_floquet_modulus: np.ndarray
    relative_residual: np.ndarray
    iterations: np.ndarray
    integration_steps: np.ndarray
    step: np.ndarray
    multipliers: np.ndarray
    state0: np.ndarray
    output_dofs: list[int]
    phase_dof: int
    events: list[ResponseEvent]
    parameter: str
    force: Force
    stop: str
    stop_kind: str
    integrator: str
    stats: dict[str, int]
    wall_time: float
    model: "Model | None"

    def __init__(self, model: "Model", raw: dict[str, Any], parameter: str, force: Force) -> None:
        self.model = model
        self._damping = model._damping
        self.parameter = parameter
        self.force = force
        events = raw.pop("events")
        raw.pop("error", None)
        dofs = raw.pop("dofs")
        for key, value in raw.items():
            setattr(self, key, value)
        if self.state0.shape[0] == 0:
            self.state0 = self.state0.reshape(0, 2 * dofs)
            self.multipliers = self.multipliers.reshape(0, 2 * dofs)
        self.events = [ResponseEvent(**e) for e in events]

    def __len__(self) -> int:
        return len(self.frequency)

    def __repr__(self) -> str:
        level = f"a = {self.force_amplitude[0]:.6g}" if self.parameter == "frequency" and len(self) else ""
        if self.parameter == "amplitude" and len(self):
            level = f"Ω = {self.frequency[0]:.6g} rad/s"
        return f"<nnm.Response in {self.parameter} ({level}): {len(self)} points, {len(self.events)} events, {self.stop}>"

    def __getstate__(self) -> dict[str, Any]:
        # The model lives in the library and does not pickle (as for a Branch).
        state = dict(self.__dict__)
        state["model"] = None
        state["_damping"] = None
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)

    @property
    def folds(self) -> list[ResponseEvent]:
        """The events of kind ``"fold"``."""
        return [e for e in self.events if e.kind == "fold"]

    def motion(self, i: int, samples: int = 100, tolerance: float = 1e-10) -> Motion:
        """The forced motion of point ``i`` over one forcing period ``2π/Ω``, at ``samples + 1``
        equal times from ``t = 0`` (the force's phase 0; the last sample closes the orbit),
        each segment integrated adaptively (DOP853) to relative ``tolerance``. ``i`` counts as
        the arrays do (``-1`` is the last point)."""
        n = len(self)
        points = f"{n} point{'' if n == 1 else 's'} (0 to {n - 1}, or -{n} to -1 from the end)" if n else "no points"
        i = _checks.index("the point index", i, n, f"point {{}} does not exist: the response has {points}")
        if self.model is None:
            raise ValueError("this response was unpickled without its model: motion() needs the model")
        samples = _checks.samples(samples, self.model.dofs)
        tolerance = _checks.real("tolerance", tolerance)
        omega = float(self.frequency[i])
        # The force at unit amplitude: the native shape is the force's, scaled by the point's
        # force amplitude (as the curve was computed).
        z = _nnm.forced_motion(
            self.model._native,
            self._damping,
            self.force.to_dict(),
            np.ascontiguousarray(self.state0[i]),
            omega,
            float(self.force_amplitude[i]),
            samples,
            tolerance,
        )
        dofs = self.model.dofs
        t = np.linspace(0.0, 2 * np.pi / omega, z.shape[0])
        return Motion(t, z[:, :dofs], z[:, dofs:])

    def to_pandas(self) -> "pandas.DataFrame":
        """One row per point, with the columns of ``<name>.csv``."""
        return _csv_frame(self, _RESPONSE_COLUMNS)

    def plot(self, ax: "matplotlib.axes.Axes | None" = None, dof: int | None = None, **kwargs: Any) -> "matplotlib.axes.Axes":
        """The peak of output dof ``dof`` (default: the first) against the frequency (or the
        force amplitude, for a curve continued in it): stable stretches solid, unstable
        dashed, folds marked with circles and other events with triangles. ``kwargs`` go to
        matplotlib's ``plot`` (e.g. ``color``, ``label``)."""
        return _plot([self], ax, dof, **kwargs)


Response.__doc__ = (Response.__doc__ or "") + "\n    Point columns (array, unit: meaning):\n\n" + _columns_doc(
    _RESPONSE_COLUMNS
)


class Responses(list):
    """The curves of several force levels (``amplitudes=[...]``), in the order given: a list
    of :class:`Response`, with :meth:`plot` (every level on one axes) and :meth:`to_pandas`
    (the rows of every level, which ``curve`` tells apart: ``<name>.csv`` of a job's
    ``[[response]]`` with these ``amplitudes``)."""

    def plot(self, ax: "matplotlib.axes.Axes | None" = None, dof: int | None = None, **kwargs: Any) -> "matplotlib.axes.Axes":
        """Every level's curve as :meth:`Response.plot` draws one, labelled by its force
        amplitude, in one colour a level."""
        return _plot(list(self), ax, dof, **kwargs)

    def to_pandas(self) -> "pandas.DataFrame":
        """The points of every level, one after another."""
        import pandas

        return pandas.concat([r.to_pandas() for r in self], ignore_index=True)


def _plot(responses: list[Response], ax: Any, dof: int | None, **kwargs: Any) -> Any:
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots()
    several = len(responses) > 1
    for r in responses:
        k = 0 if dof is None else _output_column(r, dof)
        x = r.frequency if r.parameter == "frequency" else r.force_amplitude
        y = r.peaks[:, k] if r.peaks.shape[1] else np.full(len(r), np.nan)
        style = dict(kwargs)
        if several and "label" not in kwargs:
            style["label"] = f"a = {r.force.amplitude if not len(r) else r.force_amplitude[0]:.4g}" if r.parameter == "frequency" else None
        color = style.pop("color", None)
        label = style.pop("label", None)
        line = None
        start = 0
        stable = np.asarray(r.stable, dtype=bool)
        # Runs of equal stability, each drawn to the first point of the next so the curve
        # stays connected where stability changes.
        while start < len(r):
            end = start + 1
            while end < len(r) and stable[end] == stable[start]:
                end += 1
            stop = min(end + 1, len(r))
            line = ax.plot(
                x[start:stop],
                y[start:stop],
                linestyle="-" if stable[start] else "--",
                color=color if line is None else line[0].get_color(),
                label=label if line is None else None,
                **style,
            )
            color = line[0].get_color()
            start = end
        for e in r.events:
            ex = e.frequency if r.parameter == "frequency" else e.force_amplitude
            ey = e.peaks[k] if len(e.peaks) > k else np.nan
            marker = {"fold": "o", "phase-resonance": "v"}.get(e.kind, "^")
            ax.plot([ex], [ey], marker=marker, color=color, linestyle="none",
                    markerfacecolor="none" if e.kind == "fold" else color)
    first = responses[0] if responses else None
    if first is not None:
        d = first.output_dofs[0 if dof is None else _output_column(first, dof)] if first.output_dofs else "?"
        ax.set_xlabel("frequency Ω (rad/s)" if first.parameter == "frequency" else "force amplitude")
        ax.set_ylabel(f"peak |x{d}|")
    if several:
        ax.legend()
    return ax


def _output_column(r: Response, dof: int) -> int:
    d = _checks.integer("dof", dof)
    if d not in r.output_dofs:
        raise ValueError(f"dof {d} is not an output dof of this response (its output dofs: {r.output_dofs})")
    return r.output_dofs.index(d)


def _pair(name: str, value: Any, what: str) -> tuple[float, float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise TypeError(f"{name} must be ({what}), got {value!r}")
    return _checks.real(name, value[0]), _checks.real(name, value[1])


def _progress(show: bool | None, description: str) -> tuple[Callable[..., Any] | None, Any]:
    if show is False:
        return None, None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        if show:
            raise
        return None, None
    bar = tqdm(desc=description, unit=" points", delay=0.0 if show else 1.0, leave=bool(show))

    def update(index: int, frequency: float, amplitude: float, stable: bool) -> None:
        bar.set_postfix_str(f"Ω = {frequency:.6g} rad/s, a = {amplitude:.4g}", refresh=False)
        bar.update(1)

    return update, bar


def _curve(
    model: "Model",
    force: Force,
    sweep: tuple[str, float, float, float],
    output_dofs: Sequence[int] | None,
    settings: dict[str, Any],
    curve: int,
    progress: bool | None,
    callback: Callable[[int, float, float, bool], Any] | None,
    raise_on_failure: bool,
    done: list[Response],
) -> Response:
    """One native curve with the progress bar and callback; Ctrl-C (or the callback's
    exception) raised with the points so far on ``response`` (and every finished level on
    ``responses``); a failure raised as :class:`ContinuationError` unless
    ``raise_on_failure`` is False."""
    parameter = sweep[0]
    update, bar = _progress(progress, f"response {parameter}")

    def observe(index: int, frequency: float, amplitude: float, stable: bool) -> Any:
        if update is not None:
            update(index, frequency, amplitude, stable)
        if callback is not None:
            return callback(index, frequency, amplitude, stable)
        return None

    dofs = None if output_dofs is None else [_nonnegative("output dof", d) for d in output_dofs]
    try:
        raw = _nnm.response(
            model._native,
            model._damping,
            force.to_dict(),
            sweep,
            dofs,
            settings,
            curve,
            observe if (update is not None or callback is not None) else None,
        )
    except BaseException as error:
        partial = error.__dict__.pop("partial", None)
        if isinstance(partial, dict):
            response = Response(model, partial, parameter, force)
            error.response = response  # type: ignore[attr-defined]
            error.responses = Responses([*done, response])  # type: ignore[attr-defined]
            if isinstance(error, KeyboardInterrupt) and hasattr(error, "add_note"):
                error.add_note(
                    f"nnm: interrupted; the {len(response)} points computed so far are on this exception's "
                    "`response` (and every finished force level on `responses`)"
                )
        raise
    finally:
        if bar is not None:
            bar.close()
    error_message = raw.get("error")
    response = Response(model, raw, parameter, force)
    if error_message is not None and raise_on_failure:
        failure = ContinuationError(error_message, response)  # type: ignore[arg-type]
        failure.response = response  # type: ignore[attr-defined]
        raise failure
    return response


def _check_model(model: Any) -> None:
    from ._model import Model

    if not isinstance(model, Model):
        raise TypeError(f"model must be an nnm.Model, got {type(model).__name__}")


def frequency_response(
    model: "Model",
    force: Force | dict[str, Any],
    frequency: tuple[float, float],
    *,
    amplitudes: Sequence[float] | None = None,
    output_dofs: Sequence[int] | None = None,
    progress: bool | None = None,
    callback: Callable[[int, float, float, bool], Any] | None = None,
    raise_on_failure: bool = True,
    **settings: Any,
) -> "Response | Responses":
    """The forced response of ``model`` (with its damping: ``Model(..., damping=...)``) to
    ``force`` over the forcing frequency ``frequency = (Ω_start, Ω_end)`` (rad/s,
    ``0 < Ω_start < Ω_end``), as the job file's ``[[response]]`` with ``frequency_start`` and
    ``frequency_end``: from the exact linear response at ``Ω_start`` through folds (the curve
    may run backwards in Ω between them) until Ω leaves the interval, each point with its
    Floquet stability; folds and bifurcations located (``events=False`` turns that off).

    ``force`` is a :class:`Force` or a dict of its keys. ``amplitudes=[a1, a2, ...]`` computes
    one curve per force level and returns them as :class:`Responses` (a list); without it one
    :class:`Response` at the force's own amplitude. Forced dofs are in the full numbering
    (before ``fixed_dofs``, as springs' dofs; see :class:`Force`). ``output_dofs`` (0-based,
    in the numbering of the model computed, after ``fixed_dofs``, as a job file's): the dofs
    whose peaks each point records (default: the forced dofs, in that numbering; for an engine
    order every blade's).

    Other keywords are the response's settings, with the job file's names, meanings and
    defaults: ``tolerance``, ``initial_step``, ``min_step``, ``max_step``,
    ``max_iterations``, ``target_iterations``, ``max_turn_angle`` (steps are absolute in
    unknowns scaled so that the whole curve spans a few units; first 0.02, at most 0.1),
    ``integrator``, ``integration_factor``, ``events``, ``max_points`` (default 2000) and
    ``samples`` (of a period, for the peaks; default 32) — every default in
    ``nnm.RESPONSE_DEFAULTS``. An unknown keyword raises ``ValueError`` listing them
    (``nnm.RESPONSE_SETTINGS_KEYS``).

    The computation runs without the GIL. Ctrl-C stops it between points, raising
    ``KeyboardInterrupt`` whose ``response`` holds the points computed so far (``responses``:
    the finished levels and that one); ``callback(index, frequency, force_amplitude,
    stable)`` is called after every point and stops the curve by returning ``False``; with
    tqdm installed a progress bar shows once a curve takes more than a second
    (``progress=True``: at once, ``False``: never).

    Raises ``ValueError`` for bad input (``frequency_end ≤ frequency_start``, a zero force,
    forced dofs out of range or fixed, an engine order on a non-cyclic model, ...) with the job file's
    one-line message, and :class:`nnm.ContinuationError` (its ``response``: the points so
    far) when the curve cannot be followed to the end of the interval, unless
    ``raise_on_failure=False``, which returns that curve (see ``stop_kind``)."""
    _check_model(model)
    force = Force._of(force)
    start, end = _pair("frequency", frequency, "frequency_start, frequency_end")
    if amplitudes is None:
        levels = [force.amplitude]
    else:
        if isinstance(amplitudes, (str, bytes)) or not hasattr(amplitudes, "__iter__"):
            raise TypeError(f"amplitudes must be a sequence of force amplitudes, got {amplitudes!r}")
        levels = [_checks.real("amplitudes", a) for a in amplitudes]
        if not levels:
            raise ValueError("amplitudes is empty: give at least one force amplitude")
    unit = force
    if "amplitude" in force.to_dict():
        unit = Force(**{**force.to_dict(), "amplitude": 1.0})
    done: list[Response] = []
    for k, a in enumerate(levels):
        curve = _curve(
            model, unit, ("frequency", start, end, a), output_dofs, settings, k,
            progress, callback, raise_on_failure, done,
        )
        curve.force = Force(**{**force.to_dict(), "amplitude": a}) if "amplitude" in force.to_dict() else force
        done.append(curve)
    return done[0] if amplitudes is None else Responses(done)


def force_response(
    model: "Model",
    force: Force | dict[str, Any],
    frequency: float,
    amplitude_max: float,
    *,
    output_dofs: Sequence[int] | None = None,
    progress: bool | None = None,
    callback: Callable[[int, float, float, bool], Any] | None = None,
    raise_on_failure: bool = True,
    **settings: Any,
) -> Response:
    """The response at the fixed forcing frequency ``frequency`` (rad/s) continued in the
    force amplitude, from the force's own amplitude up to ``amplitude_max``: the job file's
    ``[[response]]`` with ``parameter = "amplitude"``, ``frequency`` and ``amplitude_max``.
    Near a softening or hardening resonance the curve is S-shaped (folds in the amplitude).
    A vector force is scaled by the amplitude (its own counts as 1). Everything else as for
    :func:`frequency_response`; the result's ``parameter`` is ``"amplitude"``."""
    _check_model(model)
    force = Force._of(force)
    omega = _checks.real("frequency", frequency)
    top = _checks.real("amplitude_max", amplitude_max)
    unit = Force(**{**force.to_dict(), "amplitude": 1.0}) if "amplitude" in force.to_dict() else force
    curve = _curve(
        model, unit, ("amplitude", force.amplitude, top, omega), output_dofs, settings, 0,
        progress, callback, raise_on_failure, [],
    )
    curve.force = force
    return curve


def job_response(model: "Model", name: str, **kwargs: Any) -> "Response | Responses":
    """The ``[[response]]`` ``name`` of the job file ``model`` came from
    (``Model.from_job``), computed on ``model`` with its damping — e.g. a mistuned variant of
    the job's disk: :func:`frequency_response` (or :func:`force_response` for ``parameter =
    "amplitude"``) with the table's force, range, levels, output dofs and settings; a
    :class:`Response`, or :class:`Responses` when the table lists ``amplitudes``. ``kwargs``
    are those functions' own (``progress``, ``callback``, ``raise_on_failure``) or settings
    that replace the table's. A ``ValueError`` names the job's responses
    (``model.responses``) when it has no ``name``."""
    _check_model(model)
    table = dict(model._native.job_response(name))
    force = table.pop("force")
    output_dofs = table.pop("output_dofs", None)
    if table.pop("parameter", "frequency") == "amplitude":
        if "vector" in force:
            raise ValueError(
                f"response `{name}`: an amplitude sweep of a vector force runs with `nnm run`; from Python call "
                "nnm.force_response with the vector scaled to the start"
            )
        frequency = table.pop("frequency")
        top = table.pop("amplitude_max")
        start = table.pop("amplitude_start", None)
        if start is not None:
            force = {**force, "amplitude": start}
        else:
            force = {**force, "amplitude": 1e-3 * top}  # the job file's AMPLITUDE_START_RATIO
        return force_response(model, force, frequency, top, output_dofs=output_dofs, **{**table, **kwargs})
    frequency = (table.pop("frequency_start"), table.pop("frequency_end"))
    amplitudes = table.pop("amplitudes", None)
    return frequency_response(model, force, frequency, amplitudes=amplitudes, output_dofs=output_dofs, **{**table, **kwargs})
