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
