"""The numbers a caller hands the API, checked before anything is computed or allocated: a
value of the wrong type is a ``TypeError`` (a string is not a number, even one that reads as
one), a value out of range a ``ValueError``, each with a one-line message naming the argument.

The types follow the job file's, as the keyword settings do (``convert.rs``): an integer is
anything with ``__index__``, a real number anything with ``__float__``; a boolean is neither
(a job file's ``true`` is not 1), nor is a complex number."""

from __future__ import annotations

import operator
import os
from decimal import Decimal
from typing import Any

import numpy as np


# Integers of up to 24 digits (every 64-bit one, and as long as the library's longest number)
# are shown in full.
_FULL_INTEGER = 10**24


def number(value: Any) -> str:
    """A number a caller gave, for a message, short as the library's (``nnm::number::Number``):
    a float as ``repr`` writes it without the ``+`` and the ``.0`` (``1e300``, ``-2.5e-310``,
    ``0.25``, ``5``, ``NaN``, ``inf``); an integer in full up to 24 digits, beyond them in
    scientific notation with at most 17 significant digits (``10**400`` is ``1e400``, not its
    401 digits). Anything else as ``str`` gives it."""
    if _is_bool(value) or not isinstance(value, (int, float, np.integer, np.floating)):
        return str(value)
    if isinstance(value, (int, np.integer)):
        i = int(value)
        if -_FULL_INTEGER < i < _FULL_INTEGER:
            return str(i)
        text = format(Decimal(i), ".16e")
    else:
        text = repr(float(value))
        if text == "nan":
            return "NaN"
    return _short(text)


def _short(text: str) -> str:
    """A number's text without what the library's numbers leave out: the ``.0`` of a whole
    number, trailing zeros of a mantissa, the exponent's ``+`` and leading zeros."""
    if "e" not in text.lower():
        return text[:-2] if text.endswith(".0") else text
    mantissa, exponent = text.lower().split("e")
    if "." in mantissa:
        mantissa = mantissa.rstrip("0").rstrip(".")
    return f"{mantissa}e{int(exponent)}"


def _is_bool(value: Any) -> bool:
    return isinstance(value, (bool, np.bool_))


def _int(name: str, value: Any) -> int:
    """``value`` as an int of any size: a ``TypeError`` unless it is an integer."""
    if _is_bool(value) or not hasattr(type(value), "__index__"):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    return operator.index(value)


# A job file's integers are 64-bit (TOML): the library takes none beyond them.
_INTEGER_RANGE = range(-(2**63), 2**63)


def integer(name: str, value: Any) -> int:
    """``value`` as an int: a ``TypeError`` unless it is an integer (numpy's too), a
    ``ValueError`` beyond a job file's 64-bit integers (the native module's conversion would
    raise ``OverflowError``)."""
    i = _int(name, value)
    if i not in _INTEGER_RANGE:
        raise ValueError(f"`{name}` = {number(i)} is out of range")  # as a keyword setting's
    return i


def real(name: str, value: Any) -> float:
    """``value`` as a float: a ``TypeError`` unless it is a real number (an int, a float,
    numpy's scalars); NaN and infinities pass, for the library's own message."""
    if _is_bool(value) or isinstance(value, (complex, np.complexfloating)) or not hasattr(type(value), "__float__"):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    try:
        return float(value)
    except (TypeError, ValueError):  # an array of several values
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}") from None
    except OverflowError:  # an int beyond the doubles (10**400): not its 400 digits
        raise ValueError(f"{name} must be a finite real number, got an integer beyond the float range") from None


def holds_bool(values: Any) -> bool:
    """Whether a (nested) list or tuple of numbers holds a boolean, or ``values`` is a numpy
    boolean array: numpy reads ``[True, 0.5]`` as ``[1.0, 0.5]``, which would pass a dtype
    check."""
    if _is_bool(values):
        return True
    if isinstance(values, np.ndarray):
        return values.dtype.kind == "b"
    if isinstance(values, (list, tuple)):
        return any(holds_bool(v) for v in values)
    return False


def index(name: str, value: Any, count: int, message: str) -> int:
    """``value`` as an index into ``count`` items, Python-style (``-1`` is the last), made
    non-negative; out of range a ``ValueError`` with ``message`` (formatted with ``value``)."""
    i = _int(name, value)
    if not -count <= i < count:
        raise ValueError(message.format(number(i)))
    return i + count if i < 0 else i


# Physical memory assumed where the system does not say (Windows): a modest machine's.
_FALLBACK_MEMORY = 8 * 2**30


def physical_memory() -> int:
    """The machine's physical memory in bytes."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return _FALLBACK_MEMORY


def _gigabytes(size: int) -> str:
    """A byte count in GB to three digits, as ``.3g`` writes it, of any size (``size / 1e9``
    overflows beyond the doubles: ``samples=10**400``)."""
    try:
        return f"{size / 1e9:.3g}"
    except OverflowError:
        return _short(format(Decimal(size) / 10**9, ".3g"))


def samples(value: Any, dofs: int) -> int:
    """A motion's sample count: an integer from 1 up to what fits in half the machine's memory.

    At its peak a call holds every sample twice (the library's list of states, then the numpy
    array it is copied into): ``2 × 2n`` doubles, plus the list's ~64 bytes per state and the
    time value — ``32 n + 72`` bytes a sample. Half the physical memory leaves the rest for
    the process and the machine; beyond it the allocation would fail (aborting the
    interpreter) or swap for hours, long before the integration could finish."""
    count = _int("samples", value)
    if count < 1:
        raise ValueError(f"samples must be at least 1, got {number(count)}")
    per_sample = 32 * dofs + 72
    budget = physical_memory() // 2
    most = budget // per_sample - 1
    if count > most:
        raise ValueError(
            f"samples={number(count)} would need {_gigabytes((count + 1) * per_sample)} GB for a motion of {dofs} dofs, "
            f"more than half of this machine's {2 * budget / 1e9:.3g} GB of memory: at most {most} samples"
        )
    return count
