"""Figures of NNM results with matplotlib (imported only when a figure is asked for).

- :func:`fep`: the frequency–energy plot of branches (log energy; stable parts solid,
  unstable dashed; events marked F, BP, PD, NS), as ``nnm run`` draws ``fep.png``;
- :func:`amplitude`: the amplitude–frequency backbone (peak displacement of an output dof
  against frequency), as ``nnm run`` draws ``amplitude.png``;
- :func:`mode_shape`: a linear mode's or an NNM's deflected shape, dof by dof;
- :func:`time_series`: a point's motion over one period.

Each takes an optional ``ax`` and returns the axes it drew on.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Iterable, Sequence

import numpy as np

from . import _checks

if TYPE_CHECKING:
    import matplotlib.axes

    from ._branch import Branch, Motion


def _axes(ax: "matplotlib.axes.Axes | None") -> "matplotlib.axes.Axes":
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    return plt.figure().add_subplot()


def _runs(stable: np.ndarray) -> list[tuple[int, int, bool]]:
    """``(start, stop, stable)`` of the maximal runs of equal stability; consecutive runs share
    their boundary point so that the curve stays connected."""
    runs = []
    start = 0
    for k in range(1, len(stable) + 1):
        if k == len(stable) or stable[k] != stable[start]:
            runs.append((start, min(k + 1, len(stable)), bool(stable[start])))
            start = k
    return runs


def _regime_entries(branch: "Branch") -> list[tuple[int, str]]:
    """The first point of each stretch in a tongue or on another family, with its ratio
    (``"3:1"``, ``"→3:1"`` for another family), as ``nnm run`` marks them on ``fep.png``."""
    entries, previous = [], None
    for i, (kind, partner, ratio) in enumerate(zip(branch.regime, branch.partner_mode, branch.ratio)):
        key = (kind, None if np.isnan(partner) else int(partner))
        if key != previous and kind in ("tongue", "other-family"):
            entries.append((i, ("→" if kind == "other-family" else "") + ratio))
        previous = key
    return entries


def fep(
    branches: Iterable["Branch"],
    ax: "matplotlib.axes.Axes | None" = None,
    labels: Sequence[str] | None = None,
    events: bool = True,
) -> "matplotlib.axes.Axes":
    """Frequency (rad/s) against energy (log axis) of every branch: stable parts solid,
    unstable dashed, one colour per branch, located events marked with their abbreviation and
    the entries into internal resonances ringed with their ratio (``events=False``: neither)."""
    ax = _axes(ax)
    for k, branch in enumerate(branches):
        label = labels[k] if labels is not None else f"mode {branch.mode_label or branch.mode}"
        colour = f"C{k % 10}"
        for start, stop, stable in _runs(branch.stable):
            ax.plot(
                branch.energy[start:stop],
                branch.frequency[start:stop],
                color=colour,
                linestyle="-" if stable else "--",
                label=label if start == 0 else None,
            )
        if events:
            for e in branch.events:
                ax.plot(e.energy, e.frequency, "o", color=colour, markersize=4)
                ax.annotate(e.abbreviation, (e.energy, e.frequency), textcoords="offset points", xytext=(4, 4))
            for i, text in _regime_entries(branch):
                ax.plot(branch.energy[i], branch.frequency[i], "o", mfc="none", color=colour, markersize=7)
                ax.annotate(text, (branch.energy[i], branch.frequency[i]), textcoords="offset points", xytext=(4, -12))
    ax.set_xscale("log")
    ax.set_xlabel("total energy E = kinetic + potential (units of the model)")
    ax.set_ylabel("frequency ω (rad/s)")
    ax.set_title("Frequency–energy plot (dashed: unstable)")
    ax.legend()
    return ax


def amplitude(
    branches: Iterable["Branch"],
    ax: "matplotlib.axes.Axes | None" = None,
    labels: Sequence[str] | None = None,
    dof: int = 0,
    hz: bool = False,
) -> "matplotlib.axes.Axes":
    """The amplitude–frequency backbone of every branch: ``peak_displacement[:, dof]`` (the
    ``dof``-th of the branch's ``output_dofs``) against frequency (rad/s, or Hz with ``hz``),
    stable parts solid, unstable dashed — the curve a test engineer compares with a measured
    backbone."""
    branches = list(branches)
    for branch in branches:  # every branch checked before anything is drawn
        count = len(branch.output_dofs)
        _checks.index("dof", dof, count, f"dof {{}} is not one of the branch's {count} output_dofs")
    ax = _axes(ax)
    for k, branch in enumerate(branches):
        label = labels[k] if labels is not None else f"mode {branch.mode_label or branch.mode}"
        label += f", x{branch.output_dofs[dof]}"
        colour = f"C{k % 10}"
        frequency = branch.frequency_hz if hz else branch.frequency
        for start, stop, stable in _runs(branch.stable):
            ax.plot(
                frequency[start:stop],
                branch.peak_displacement[start:stop, dof],
                color=colour,
                linestyle="-" if stable else "--",
                label=label if start == 0 else None,
            )
    ax.set_xlabel("frequency (Hz)" if hz else "frequency ω (rad/s)")
    ax.set_ylabel("peak displacement over the period (units of the model)")
    ax.set_title("Amplitude–frequency backbones (dashed: unstable)")
    ax.legend()
    return ax


def mode_shape(
    shape: np.ndarray, ax: "matplotlib.axes.Axes | None" = None, label: str | None = None
) -> "matplotlib.axes.Axes":
    """A shape (``modes.shapes[:, k]`` or ``branch.displacement0[i]``) dof by dof."""
    ax = _axes(ax)
    shape = np.asarray(shape)
    ax.plot(np.arange(len(shape)), shape, "o-", label=label)
    ax.set_xlabel("dof")
    ax.set_ylabel("displacement")
    if label is not None:
        ax.legend()
    return ax


def time_series(
    motion: "Motion", dofs: Sequence[int] | None = None, ax: "matplotlib.axes.Axes | None" = None
) -> "matplotlib.axes.Axes":
    """Displacements of ``dofs`` (default: all, up to 10) over one period of a
    :meth:`Branch.motion`."""
    n = motion.x.shape[1]
    message = f"dof {{}} does not exist: the motion has {n} dofs"
    chosen = [_checks.index("dofs", d, n, message) for d in dofs] if dofs is not None else list(range(min(n, 10)))
    ax = _axes(ax)
    for d in chosen:
        ax.plot(motion.t, motion.x[:, d], label=f"x{d}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("displacement")
    ax.legend()
    return ax


__all__ = ["amplitude", "fep", "mode_shape", "time_series"]
