"""What counts as a number, decided once for every value a user gives: a scene's field, a
``Simulation`` method's argument, a saved state's entry, an env's or a controller's argument.

Each check reads its value through these and raises its own error naming the field
(``SceneError`` for a scene, ``ValueError`` or ``TypeError`` for an argument, as each
documents). A real number is a Python or numpy int or float, another ``numbers.Real`` (a
``Fraction``), or a 0-d array of one; a bool is not a number anywhere (``True`` as a radius
or a step count is a mistake, not a 1)."""

from __future__ import annotations

import math
import numbers

import numpy as np


def plain(value):
    """A numpy scalar as the Python number it is (``np.bool_`` -> bool, ``np.integer`` -> int,
    ``np.floating`` -> float: a float32 radius becomes ``float(value)``); anything else as
    given. Applied once where a number enters, so every later check and the values stored are
    the ones the Python number would give."""
    if isinstance(value, np.generic):
        if isinstance(value, np.bool_):
            return bool(value)
        if isinstance(value, np.integer):
            return int(value)
        if isinstance(value, np.floating):
            return float(value)
    return value


def real(value) -> int | float | None:
    """``value`` as a Python int or float if it is a real number, else None (a bool, a
    string, None, an array of more than one value)."""
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value[()]
    value = plain(value)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None
    return value if isinstance(value, (int, float)) else as_float(value)


def integer(value, *, integral_float: bool = False) -> int | None:
    """``value`` as a Python int if it is an integer (with ``integral_float``, also a finite
    float with no fraction: ``3.0``), else None."""
    v = real(value)
    if isinstance(v, int):
        return v
    if integral_float and isinstance(v, float) and v.is_integer():  # (False for inf, nan)
        return int(v)
    return None


def number_in(value, lo: float, hi: float, *, lo_open: bool = False,
              hi_open: bool = False) -> float | None:
    """``value`` as a float if it is a finite real number in [lo, hi] (``lo_open``,
    ``hi_open``: without that end), else None: a range check's one reading of its value."""
    x = real(value)
    if x is None:
        return None
    f = as_float(x)
    if not math.isfinite(f) or f < lo or f > hi or (lo_open and f == lo) or \
            (hi_open and f == hi):
        return None
    return f


def as_float(value) -> float:
    """A real number as a float; one beyond the float range (a huge int or ``Fraction``) as
    +-inf, so that the caller's finiteness check refuses it with its own words."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf
