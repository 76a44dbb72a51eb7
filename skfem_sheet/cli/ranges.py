"""The one parser of ranges and lists of values given on the command line.

- :func:`parse_range` ``"start:stop:step"`` -> the values (stop included), or,
  with ``pair=``, ``"low:high"`` -> the two bounds;
- :func:`parse_values` ``"start:stop:step"`` or ``"x,y,z"`` -> a list.

Bad text raises ``ParameterError`` naming the option (the CLI prints it in one
line and exits with code 2).
"""
from __future__ import annotations

import math

import numpy as np

from ..params import ParameterError
from ..studies.runner import MAX_POINTS, normalize_number

__all__ = ["parse_range", "parse_values"]

_MAX_RANGE = 10000


def parse_range(text, name: str = "--lengths", max_points: int = _MAX_RANGE,
                slack: float = 1e-9, *, pair: str | None = None, example: str = ""):
    """Parse ``"a:b:step"`` into the values a, a + step, ..., <= b (b included
    within ``slack * step``); or, with ``pair`` (the form, e.g. ``"short:long"``),
    ``"a:b"`` into the tuple ``(a, b)``.

    Raises ``ParameterError`` naming ``name`` on malformed input or more than
    ``max_points`` values (``example`` is quoted in the message of a bad pair).

    Examples
    --------
    >>> parse_range("1.0:1.1:0.05").tolist()
    [1.0, 1.05, 1.1]
    >>> parse_range("0.6:2.4", "lengths", pair="short:long", example="0.6:2.4")
    (0.6, 2.4)
    >>> parse_range("0.6", "lengths", pair="short:long", example="0.6:2.4")
    Traceback (most recent call last):
    ...
    skfem_sheet.params.ParameterError: lengths must be short:long, e.g. 0.6:2.4, got '0.6'
    """
    if pair is not None:
        try:
            lo, hi = (float(x) for x in text.split(":"))
        except ValueError:
            raise ParameterError(f"{name} must be {pair}, e.g. {example}, got {text!r}") from None
        return lo, hi
    parts = str(text).split(":")
    if len(parts) != 3:
        raise ParameterError(f"{name} must be 'start:stop:step', got {text!r}")
    try:
        a, b, step = (float(x) for x in parts)
    except ValueError:
        raise ParameterError(f"{name} must be 'start:stop:step' with numbers, "
                             f"got {text!r}") from None
    if not all(math.isfinite(v) for v in (a, b, step)):
        raise ParameterError(f"{name} values must be finite, got {text!r}")
    if step <= 0:
        raise ParameterError(f"{name} step must be in (0, inf), got {step!r}")
    if b < a:
        raise ParameterError(f"{name} stop must be >= start, got {text!r}")
    n = int(math.floor((b - a) / step + slack)) + 1
    if n > max_points:
        raise ParameterError(f"{name} must have at most {max_points} points, got {n}")
    return np.round(a + step * np.arange(n), 12)


def parse_values(text, name, kind=float) -> list:
    """Parse ``"a:b:step"`` (a, a + step, ..., b inclusive within step/1e6) or ``"x,y,z"``.

    Numbers are normalised as the studies key them (10 significant digits).
    Raises ``ParameterError`` naming ``name`` on malformed input.

    Examples
    --------
    >>> parse_values("0.5:1.5:0.25", "--lengths")
    [0.5, 0.75, 1.0, 1.25, 1.5]
    >>> parse_values("1,0", "--tip-widths")
    [1.0, 0.0]
    """
    text = str(text).strip()
    if ":" in text:
        if kind is not float:
            raise ParameterError(f"{name} must be a comma list, got {text!r}")
        return [normalize_number(v) for v in parse_range(text, name, MAX_POINTS, slack=1e-6)]
    items = [t.strip() for t in text.split(",")]
    if not text or any(not t for t in items):
        raise ParameterError(f"{name} must be 'start:stop:step' or 'x,y,...', got {text!r}")
    out = []
    for t in items:
        try:
            v = kind(t)
        except ValueError:
            raise ParameterError(f"{name} must be numbers, got {t!r}") from None
        if kind is float and not math.isfinite(v):
            raise ParameterError(f"{name} values must be finite, got {t!r}")
        out.append(v)
    return out
