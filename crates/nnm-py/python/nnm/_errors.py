"""Exceptions of nnm.

Bad input (wrong shapes, NaN, a non-symmetric matrix, an unknown mode or setting) raises the
built-in ``ValueError`` or ``TypeError`` with the command line's one-line message. What is
left are numerical failures, which are not the caller's mistake and often still carry a
useful result: they have their own classes so that ``except nnm.NumericalError`` catches
them without hiding a typo.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ._branch import Branch


class NumericalError(RuntimeError):
    """A computation that did not succeed on valid input (no convergence, integration
    failure)."""


class ContinuationError(NumericalError):
    """A branch that could not be followed to its limit.

    ``branch`` holds the points computed before the failure (possibly none, when the first
    point did not converge), with ``branch.stop`` saying why it ended; the message is the
    command line's.
    """

    def __init__(self, message: str, branch: "Branch") -> None:
        super().__init__(message)
        self.branch = branch

    def __reduce__(self) -> tuple:
        # Pickled with its branch (process pools and Dask send exceptions between processes).
        return (type(self), (str(self), self.branch))
