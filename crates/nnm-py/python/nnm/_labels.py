"""Mode labels of cyclic models: ``(n, d)`` (nodal circles, nodal diameters), which the library
writes ``"n,d"``."""

from __future__ import annotations

import operator
from typing import Any


def _parse_label(text: str | None) -> tuple[int, int] | None:
    """``"n,d"`` (as the library writes labels) as ``(n, d)``."""
    if text is None:
        return None
    n, d = text.split(",")
    return int(n), int(d)


def _label(label: Any) -> str:
    """A mode as the native module takes it: a label ``(n, d)`` as ``"n,d"``, else its text."""
    if isinstance(label, tuple):
        n, d = label
        return f"{operator.index(n)},{operator.index(d)}"
    return str(label)
