"""The forms of arguments that a C++ signature cannot say, refused naming
the argument: whole numbers (2.5 is not truncated), a list of names as well
as the command line's comma string, finite JSON values. The ranges are
checked once, in C++ (host/cli/option_checks.hpp and the measurement and
simulation plans), by the same functions the command line calls."""
from __future__ import annotations

import math
import operator


def whole(name: str, value) -> int:
    """An int (or numpy integer); TypeError for 2.5, "3", True."""
    if isinstance(value, bool):
        raise TypeError(f"{name}: a whole number, got {value!r}")
    try:
        return operator.index(value)
    except TypeError:
        raise TypeError(f"{name}: a whole number, got {value!r}") from None


def number(name: str, value) -> float:
    """A real number (int, float, numpy scalar); TypeError otherwise. NaN
    passes: the range checks refuse it with the allowed range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) and not hasattr(value, "__float__"):
        raise TypeError(f"{name}: a number, got {value!r}")
    return float(value)


def numbers(name: str, value) -> list:
    """A sequence of real numbers (list, tuple, 1-D array); TypeError naming
    the argument for a string, a scalar or a nested list (no comma string:
    "1,2" is a string, not two numbers)."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise TypeError(f"{name}: a sequence of numbers, got {value!r}")
    return [number(f"{name}[{i}]", v) for i, v in enumerate(value)]


def text(name: str, value, optional: bool = False) -> str:
    """A str (None as "" where optional); TypeError naming the argument
    otherwise, before a C++ signature's own message."""
    if value is None and optional:
        return ""
    if not isinstance(value, str):
        raise TypeError(f"{name}: a string, got {value!r}")
    return value


def path(name: str, value) -> str:
    """A file path (str or os.PathLike); TypeError naming the argument."""
    import os
    try:
        return os.fspath(value)
    except TypeError:
        raise TypeError(f"{name}: a path (str or os.PathLike), got {value!r}") from None


def names(name: str, value) -> str:
    """"r,y,u" or ["r", "y", "u"] as the command line's comma string."""
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
        if any("," in v for v in value):
            raise ValueError(f"{name}: one name per list item, got {value!r}")
        return ",".join(value)
    raise TypeError(f"{name}: a list of names or a comma-separated string, got {value!r}")


def finite_json(where: str, value) -> None:
    """Every number in a JSON-bound value finite (JSON has no NaN): ValueError
    naming the field as group.field[i]."""
    if isinstance(value, dict):
        for k, v in value.items():
            finite_json(f"{where}.{k}", v)
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            finite_json(f"{where}[{i}]", v)
    elif isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"{where}: must be a finite number (got {value})")
