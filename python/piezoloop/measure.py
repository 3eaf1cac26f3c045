"""piezoloop.measure_frf: a stage's frequency response, as `piezoloop measure frf`.

The simulator here (a scenario's stage), a board through Device.measure_frf:
one implementation with the command line (host/measure, host/link), so the
response, its log_hash and the JSON are those of `piezoloop measure frf`.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Optional

import numpy as np

from . import _piezoloop

SIGNALS = ("multisine", "sweep", "prbs")


@dataclass
class FrequencyResponse:
    """A measured frequency response u (V) -> y (um).

    frequency_hz: the excited lines.
    response: G at each line, complex, um/V.
    std_db: one standard deviation of |G| per line in dB (nan with one period).
    coherence: sweep and PRBS only, else None.
    sensitivity: closed loop only, S = U / D at each line (T = 1 - S), else None.
    report: the JSON `piezoloop measure frf --out` writes (save() writes it;
        `piezoloop identify tf --frf` reads it).
    """
    frequency_hz: np.ndarray
    response: np.ndarray
    std_db: np.ndarray
    coherence: Optional[np.ndarray]
    sensitivity: Optional[np.ndarray]
    report: dict

    @property
    def log_hash(self) -> str:
        return self.report["log_hash"]

    @property
    def warnings(self) -> list:
        return self.report["warnings"]

    def save(self, path: str | os.PathLike) -> None:
        with open(path, "w") as f:
            json.dump(self.report, f, indent=1)


def _complex(pairs) -> np.ndarray:
    return np.array([complex(re, im) for re, im in pairs], dtype=complex)


def response_from_report(report: dict) -> FrequencyResponse:
    return FrequencyResponse(
        frequency_hz=np.asarray(report["frequency_Hz"], dtype=float),
        response=_complex(report["response"]),
        std_db=np.array([np.nan if x is None else x for x in report["std_db"]], dtype=float),
        coherence=np.asarray(report["coherence"], dtype=float) if "coherence" in report else None,
        sensitivity=_complex(report["sensitivity"]) if "sensitivity" in report else None,
        report=report)


def check_request(from_hz: float, to_hz: float, amplitude_v: float, mode: str, signal: str) -> None:
    """Form only; the ranges are checked by the C++ plan (ValueError naming the option)."""
    if mode not in ("open", "closed"):
        raise ValueError(f"mode: {mode!r} is not one of open, closed")
    if signal not in SIGNALS:
        raise ValueError(f"signal: {signal!r} is not one of {', '.join(SIGNALS)}")
    for name, v in (("from_hz", from_hz), ("to_hz", to_hz), ("amplitude_v", amplitude_v)):
        if not isinstance(v, (int, float)):
            raise ValueError(f"{name}: a number, got {v!r}")


def measure_frf(scenario: str | os.PathLike, from_hz: float, to_hz: float, amplitude_v: float, *,
                bias_v: float = 0.0, mode: str = "open", signal: str = "multisine", periods: int = 10,
                transient_periods: int = 1, case: Optional[str] = None,
                sample: Optional[str] = None) -> FrequencyResponse:
    """The frequency response of the scenario's simulated stage, as
    `piezoloop measure frf --scenario`: open loop (no controller, the command
    bias_v + d) or closed loop (mode="closed": the case's controller, d added
    to its output). A request beyond the scenario's limits, Nyquist or the
    multisine's longest period raises ValueError naming the option."""
    check_request(from_hz, to_hz, amplitude_v, mode, signal)
    if sample not in (None, "float", "q31"):
        raise ValueError(f"sample: {sample!r} is not one of float, q31")
    report = _piezoloop.measure_frf(os.fspath(scenario), case or "", sample or "", float(from_hz), float(to_hz),
                                    float(amplitude_v), float(bias_v), mode, signal, int(periods),
                                    int(transient_periods))
    return response_from_report(report)
