"""piezoloop.sim: one closed-loop run of a scenario case, as `piezoloop sim`."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Dict, Mapping, Optional, Union

import numpy as np

from . import _piezoloop
from ._args import number, path, text, whole


@dataclass
class SimRun:
    """A simulated run.

    signals: numpy arrays over the whole run (one row per logged tick):
        tick, t_s, r_um (reference), y_um (measured position), e_um (r - y),
        u_V (controller output), u_ff_V, u_fb_V, v_piezo_V, x_um.
        A stage of coupled axes: tick, t_s and per axis A the columns of
        `piezoloop sim --out`: r_A_um, y_A_um, u_A_V (its channel's
        command), p_A_um (its true position).
    metrics: the JSON `piezoloop sim` prints (tracking figures of the last
        reference period, e_max_um, e_rms_um, hysteresis_pct, log_hash, ...;
        several axes: also axis, axes (per axis its figures) and
        cross_motion_pct (per held axis)).
    log_hash: hash of r, y and u over the run, as `piezoloop sim --hash`.
    """
    signals: Dict[str, np.ndarray]
    metrics: dict
    log_hash: str = field(default="")


def _holds(hold_um) -> list:
    """hold_um as the command line's --hold-um values: "NAME=UM" per axis, or
    "UM" for every held axis (repr: the shortest text of the same double)."""
    if hold_um is None:
        return []
    if isinstance(hold_um, Mapping):
        out = []
        for name, v in hold_um.items():
            if not isinstance(name, str) or not name or "=" in name:
                raise TypeError(f"hold_um: keys are axis names, got {name!r}")
            out.append(f"{name}={number(f'hold_um[{name!r}]', v)!r}")
        return out
    return [repr(number("hold_um", hold_um))]


def sim(scenario: str | os.PathLike, case: str, trajectory: str = "triangle", frequency_hz: float = 10.0,
        amplitude_um: Optional[float] = None, duration_s: Optional[float] = None, sample: Optional[str] = None,
        fidelity: str = "float", *, amplitude_v: Optional[float] = None, offset: Optional[str] = None,
        substeps: int = 10, log_every: int = 0, midpoint_um: Optional[float] = None, axis: Optional[str] = None,
        hold_um: Union[None, float, Mapping[str, float]] = None) -> SimRun:
    """Run `case` of the scenario file `scenario` (configs/*.json) on the host.

    trajectory: "triangle" or "sine" at frequency_hz (Hz), with a
    peak-to-peak range of amplitude_um (um) or amplitude_v (piezo volts,
    converted at the stage's mean slope); exactly one of the two.
    offset: "unipolar" (from 0 up) or "bipolar" (centred on 0); default the
    scenario's. duration_s: simulated seconds (default two periods; the
    last full period is measured). sample: the core's sample type, "float"
    or "q31" (default the case's). fidelity: "float" (the boards' stage
    model) or "double" (continuous, `substeps` per tick). log_every: keep
    every N-th tick in `signals` (0: at most 200000 rows, as the CLI's --out).
    midpoint_um: the wave's midpoint (instead of offset's).
    A scenario of coupled axes (configs/stages/xy_flexure.json, ...) needs
    axis, the axis that runs the wave (ValueError naming the axes without
    it); the others hold hold_um: {"y": 50} per axis, or one number for
    every held axis (default: the wave's first value). Its fidelity is
    "float" only.
    The GIL is released while the loop runs.
    """
    # The ranges and choices are checked in C++ (sim::check_sim_request), as
    # `piezoloop sim` checks them.
    opt = lambda name, v: 0.0 if v is None else number(name, v)
    r = _piezoloop.sim(path("scenario", scenario), text("case", case), text("trajectory", trajectory),
                       number("frequency_hz", frequency_hz), opt("amplitude_um", amplitude_um),
                       opt("amplitude_v", amplitude_v), text("offset", offset, True),
                       None if midpoint_um is None else number("midpoint_um", midpoint_um),
                       opt("duration_s", duration_s), text("sample", sample, True), text("fidelity", fidelity),
                       whole("substeps", substeps), True, whole("log_every", log_every), text("axis", axis, True),
                       _holds(hold_um))
    return SimRun(signals=r["signals"], metrics=r["metrics"], log_hash=r["metrics"]["log_hash"])
