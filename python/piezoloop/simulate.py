"""piezoloop.sim: one closed-loop run of a scenario case, as `piezoloop sim`."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Dict, Optional

import numpy as np

from . import _piezoloop


@dataclass
class SimRun:
    """A simulated run.

    signals: numpy arrays over the whole run (one row per logged tick):
        tick, t_s, r_um (reference), y_um (measured position), e_um (r - y),
        u_V (controller output), u_ff_V, u_fb_V, v_piezo_V, x_um.
    metrics: the JSON `piezoloop sim` prints (tracking figures of the last
        reference period, e_max_um, e_rms_um, hysteresis_pct, log_hash, ...).
    log_hash: hash of r, y and u over the run, as `piezoloop sim --hash`.
    """
    signals: Dict[str, np.ndarray]
    metrics: dict
    log_hash: str = field(default="")


def _choice(name: str, value: str, allowed) -> str:
    if value not in allowed:
        raise ValueError(f"{name}: {value!r} is not one of {', '.join(allowed)}")
    return value


def sim(scenario: str | os.PathLike, case: str, trajectory: str = "triangle", frequency_hz: float = 10.0,
        amplitude_um: Optional[float] = None, duration_s: Optional[float] = None, sample: Optional[str] = None,
        fidelity: str = "float", *, amplitude_v: Optional[float] = None, offset: Optional[str] = None,
        substeps: int = 10, log_every: int = 0) -> SimRun:
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
    The GIL is released while the loop runs.
    """
    _choice("trajectory", trajectory, ("triangle", "sine"))
    _choice("fidelity", fidelity, ("float", "double"))
    if sample is not None:
        _choice("sample", sample, ("float", "q31"))
    if offset is not None:
        _choice("offset", offset, ("unipolar", "bipolar"))
    if (amplitude_um is not None and amplitude_um > 0) == (amplitude_v is not None and amplitude_v > 0):
        raise ValueError("give exactly one of amplitude_um and amplitude_v (> 0)")
    if not 1e-4 <= frequency_hz <= 5e5:
        raise ValueError(f"frequency_hz: {frequency_hz} is outside [1e-4, 5e5]")
    if duration_s is not None and not 1e-6 <= duration_s <= 1e4:
        raise ValueError(f"duration_s: {duration_s} is outside [1e-6, 1e4]")
    r = _piezoloop.sim(os.fspath(scenario), case, trajectory, float(frequency_hz), float(amplitude_um or 0.0),
                       float(amplitude_v or 0.0), offset or "", float(duration_s or 0.0), sample or "", fidelity,
                       int(substeps), True, int(log_every))
    return SimRun(signals=r["signals"], metrics=r["metrics"], log_hash=r["metrics"]["log_hash"])
