"""piezoloop.commission: a stage commissioned from measurements alone, as
`piezoloop commission --scenario` does (the board: Device.commission).

One implementation with the command line (host/cli/commission_session), so
the summary, the files it writes and the figures are those of the command.
See docs/commissioning.md.
"""
from __future__ import annotations

import os
from typing import Callable, Mapping, Optional, Sequence, Union

from . import _piezoloop
from ._args import path


def check_commission(range_um: float, target_bandwidth_hz: Optional[float]) -> None:
    """The checks the command line makes of its options before anything
    runs (the C++ side names the same options for what it refuses)."""
    if not isinstance(range_um, (int, float)) or isinstance(range_um, bool):
        raise TypeError("range_um: a number")
    if target_bandwidth_hz is not None and (not isinstance(target_bandwidth_hz, (int, float)) or
                                            isinstance(target_bandwidth_hz, bool)):
        raise TypeError("target_bandwidth_hz: a number or None")


def commission(scenario: str | os.PathLike, range_um: Union[float, Mapping[str, float]], out: str | os.PathLike, *,
               target_bandwidth_hz: Optional[float] = None,
               progress: Optional[Callable[[str], None]] = None,
               axes: Union[None, str, Sequence[str]] = None) -> dict:
    """Commissions the scenario's stage (measured in open loop; its models
    are never read) for `range_um` of travel: safety steps, frequency
    response, hysteresis loop, fits, a robust and a classic candidate checked
    on the measured response, the best predicted verified on the stage.
    Writes report.md (with its figures), controller.json, frf.json and
    scenario.json to `out`; returns the summary (`summary["verified"]`).
    `progress` receives each step's line. Raises ValueError naming the
    option for a bad request, RuntimeError when a safety step stops it.

    A scenario of coupled axes (configs/stages/xy_flexure.json, ...) needs
    axes: every axis of the stage (["x", "y"], or "all"), as `commission
    --axes`: each axis commissioned with the others holding still (out/<axis>),
    then the static decoupling output matrix from the measured coupling, and
    the coupled stage checked with it (out/scenario.json, out/report.md).
    range_um: one number for every axis or {"x": 80, "z": 10, ...} each."""
    if axes is not None:
        if isinstance(axes, str) and axes != "all":
            raise TypeError(f"axes: a list of axis names or \"all\", got {axes!r}")
        names = list(axes) if not isinstance(axes, str) else None
        if names is not None and not all(isinstance(n, str) for n in names):
            raise TypeError(f"axes: a list of axis names, got {axes!r}")
        ranges, every = {}, 0.0
        if isinstance(range_um, Mapping):
            for k, v in range_um.items():
                if not isinstance(k, str):
                    raise TypeError(f"range_um: keys are axis names, got {k!r}")
                check_commission(v, target_bandwidth_hz)
                ranges[k] = float(v)
        else:
            check_commission(range_um, target_bandwidth_hz)
            every = float(range_um)
        return _piezoloop.commission_axes(path("scenario", scenario), names if names is not None else ["all"], ranges,
                                          every, float(target_bandwidth_hz or 0.0), path("out", out), progress)
    if isinstance(range_um, Mapping):
        raise TypeError("range_um: one number (a mapping per axis is for axes=)")
    check_commission(range_um, target_bandwidth_hz)
    return _piezoloop.commission(path("scenario", scenario), float(range_um), float(target_bandwidth_hz or 0.0),
                                 path("out", out), progress)
