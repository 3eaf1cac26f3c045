"""piezoloop.measure_frf, measure_step, measure_loops: a stage measured as
`piezoloop measure frf|step|loops` does.

The simulator here (a scenario's stage), a board through the Device's
methods of the same names: one implementation with the command line
(host/measure, host/link), so the results, their log_hash and the JSON are
those of `piezoloop measure`.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from . import _piezoloop
from ._args import number, numbers, path, text, whole

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
        number(name, v)


@dataclass
class MimoFrequencyResponse:
    """The n x n frequency response of a stage of coupled axes, as
    `piezoloop measure frf --mimo` measures it (axis commands, V -> axis
    readings, um; with an output matrix D the response G D the axes'
    controllers see).

    frequency_hz: the excited lines (L).
    response: complex, L x n x n: response[k, i, j] is y_i <- u_j at line k.
    std: L x n x n, one standard deviation of each element (|G| units; nan
        with one period).
    snr_db: L x n x n, 20 log10(|G| / std).
    axes: the axes' names, in the matrices' order.
    report: the JSON `piezoloop measure frf --mimo` prints (the summary, the
        clamped samples, log_hash, ...; not its coupling, see
        analyze_coupling).
    """
    frequency_hz: np.ndarray
    response: np.ndarray
    std: np.ndarray
    snr_db: np.ndarray
    axes: list
    report: dict

    @property
    def log_hash(self) -> str:
        return self.report["log_hash"]

    def save_csv(self, path: str | os.PathLike) -> None:
        """The CSV `piezoloop measure frf --mimo --out` writes (17 significant
        digits: read back exactly), which `piezoloop analyze coupling` reads."""
        _piezoloop.write_mimo_frf(os.fspath(path), self.frequency_hz, self.response, self.std, self.report["periods"],
                                  self.report["rate_Hz"])


def _output_matrix(value) -> Optional[list]:
    """An n x n matrix of finite or not numbers as rows; ValueError naming
    output_matrix when it is not square (the size and the values are the
    core's to check: n the axes, finite, |m| <= 16, condition <= 1000)."""
    if value is None:
        return None
    try:
        m = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"output_matrix: a square matrix of numbers, got {value!r}") from None
    if m.ndim != 2 or m.shape[0] != m.shape[1] or m.shape[0] == 0:
        raise ValueError(f"output_matrix: must be n x n (n the axes), got shape {m.shape}")
    return m.tolist()


def measure_frf(scenario: str | os.PathLike, from_hz: float, to_hz: float, amplitude_v: float, *,
                bias_v: float = 0.0, mode: str = "open", signal: str = "multisine", periods: int = 10,
                transient_periods: int = 1, case: Optional[str] = None,
                sample: Optional[str] = None, mimo: bool = False, output_matrix=None):
    """The frequency response of the scenario's simulated stage, as
    `piezoloop measure frf --scenario`: open loop (no controller, the command
    bias_v + d) or closed loop (mode="closed": the case's controller, d added
    to its output). A request beyond the scenario's limits, Nyquist or the
    multisine's longest period raises ValueError naming the option.

    mimo=True: a scenario of coupled axes measured as `measure frf --mimo`
    (open loop, orthogonal multisines on every axis at once, bias_v on
    every axis), through output_matrix (n x n rows or array, between axis
    commands and channels; default the identity): a MimoFrequencyResponse."""
    if mimo:
        if case is not None or sample is not None:
            raise ValueError(f"{'case' if case is not None else 'sample'}: not with mimo=True "
                             "(open loop on the stage alone)")
        if mode != "open":
            raise ValueError("mode: mimo=True measures open loop only")
        if signal != "multisine":
            raise ValueError("signal: mimo=True uses orthogonal multisines only")
        r = _piezoloop.measure_frf_mimo(path("scenario", scenario), number("from_hz", from_hz), number("to_hz", to_hz),
                                        number("amplitude_v", amplitude_v), number("bias_v", bias_v),
                                        whole("periods", periods), whole("transient_periods", transient_periods),
                                        _output_matrix(output_matrix))
        return MimoFrequencyResponse(frequency_hz=r["frequency_Hz"], response=r["response"], std=r["std"],
                                     snr_db=r["snr_db"], axes=list(r["report"]["axes"]), report=r["report"])
    if output_matrix is not None:
        raise ValueError("output_matrix: only with mimo=True")
    check_request(from_hz, to_hz, amplitude_v, mode, signal)
    if sample not in (None, "float", "q31"):
        raise ValueError(f"sample: {sample!r} is not one of float, q31")
    report = _piezoloop.measure_frf(path("scenario", scenario), text("case", case, True), sample or "",
                                    number("from_hz", from_hz), number("to_hz", to_hz),
                                    number("amplitude_v", amplitude_v), number("bias_v", bias_v), mode, signal,
                                    whole("periods", periods),
                                    whole("transient_periods", transient_periods))
    return response_from_report(report)


@dataclass
class StepResponse:
    """A step response, as `piezoloop measure step --out` writes it.

    time_s: 0 at the tick the step is applied (the level before it is
        recorded too).
    reference_um, command_v, response_um: r, u (after the limiter) and y.
    figures: overshoot_pct, rise_time_s (10-90 %), settling_time_s (2 %),
        initial_um, final_value_um, peak_um, peak_time_s, settled.
    report: the whole JSON (definitions, source, limiter, warnings).
    """
    time_s: np.ndarray
    reference_um: np.ndarray
    command_v: np.ndarray
    response_um: np.ndarray
    figures: dict
    report: dict

    @property
    def log_hash(self) -> str:
        return self.report["log_hash"]

    def save(self, path: str | os.PathLike) -> None:
        with open(path, "w") as f:
            json.dump(self.report, f, indent=1)


_STEP_FIGURES = ("initial_um", "final_value_um", "overshoot_pct", "peak_um", "peak_time_s", "rise_time_s",
                 "settling_time_s", "settled")


def step_from_report(report: dict) -> StepResponse:
    return StepResponse(time_s=np.asarray(report["time_s"], dtype=float),
                        reference_um=np.asarray(report["reference_um"], dtype=float),
                        command_v=np.asarray(report["command_V"], dtype=float),
                        response_um=np.asarray(report["response_um"], dtype=float),
                        figures={k: report[k] for k in _STEP_FIGURES}, report=report)


@dataclass
class Loops:
    """Hysteresis loops, as `piezoloop measure loops` writes them.

    time_s, command_v (u, after the limiter), response_um (y, read at the
    next tick), amplitude_v (the loop each sample belongs to): the CSV's
    columns. loops: per amplitude its hysteresis_pct, max_width_pct,
    y_min_um, y_max_um. report: the --json summary.
    """
    time_s: np.ndarray
    command_v: np.ndarray
    response_um: np.ndarray
    amplitude_v: np.ndarray
    loops: list
    report: dict

    def save_csv(self, path: str | os.PathLike) -> None:
        """The CSV `identify pi` (columns u, y) and `identify dahl` (v, x) read."""
        _piezoloop.write_loops_csv(os.fspath(path), self.time_s, self.command_v, self.response_um, self.amplitude_v)


def loops_from_result(r: dict) -> Loops:
    return Loops(time_s=r["time_s"], command_v=r["u_V"], response_um=r["y_um"], amplitude_v=r["amplitude_V"],
                 loops=r["report"]["loops"], report=r["report"])


def check_step(step_um, step_v, mode) -> None:
    if (step_um is None) == (step_v is None):
        raise ValueError("step_um: give exactly one of step_um (closed loop) and step_v (open loop)")
    if mode not in (None, "open", "closed"):
        raise ValueError(f"mode: {mode!r} is not one of open, closed")


def check_shape(shape: str) -> None:
    if shape not in ("triangle", "sine"):
        raise ValueError(f"shape: {shape!r} is not one of triangle, sine")


def _opt(name, v):
    return None if v is None else number(name, v)


def measure_step(scenario: str | os.PathLike, *, step_um: Optional[float] = None, step_v: Optional[float] = None,
                 from_um: Optional[float] = None, bias_v: Optional[float] = None, duration_s: float = 0.1,
                 mode: Optional[str] = None, case: Optional[str] = None,
                 sample: Optional[str] = None) -> StepResponse:
    """The step response of the scenario's simulated stage, as `piezoloop
    measure step --scenario`: open loop a command step of step_v volts from
    bias_v (default max(0, the lower limit)); closed loop (step_um, with the
    case's controller) a reference step from from_um (default 10 % into the
    range). duration_s is recorded after the step, as long before it. A
    request beyond the limits raises ValueError naming the option."""
    check_step(step_um, step_v, mode)
    if sample not in (None, "float", "q31"):
        raise ValueError(f"sample: {sample!r} is not one of float, q31")
    report = _piezoloop.measure_step(path("scenario", scenario), text("case", case, True), sample or "",
                                     _opt("step_um", step_um), _opt("step_v", step_v), _opt("from_um", from_um),
                                     _opt("bias_v", bias_v), mode or "", number("duration_s", duration_s))
    return step_from_report(report)


def measure_loops(scenario: str | os.PathLike, amplitudes_v: Sequence[float], *, bias_v: Optional[float] = None,
                  frequency_hz: float = 1.0, cycles: int = 2, shape: str = "triangle", case: Optional[str] = None,
                  sample: Optional[str] = None) -> Loops:
    """Open-loop hysteresis loops of the scenario's simulated stage, as
    `piezoloop measure loops --scenario`: per amplitude (peak-to-peak volts
    above bias_v) `cycles` triangles (or 1 - cos sines) at frequency_hz, the
    last one measured."""
    check_shape(shape)
    if sample not in (None, "float", "q31"):
        raise ValueError(f"sample: {sample!r} is not one of float, q31")
    r = _piezoloop.measure_loops(path("scenario", scenario), text("case", case, True), sample or "",
                                 numbers("amplitudes_v", amplitudes_v), _opt("bias_v", bias_v),
                                 number("frequency_hz", frequency_hz), whole("cycles", cycles), shape)
    return loops_from_result(r)


def analyze_coupling(response, *, below_hz: Optional[float] = None) -> dict:
    """How much the axes move each other and the static decoupling that
    removes it, as `piezoloop analyze coupling FILE` (the same functions):
    response is a MimoFrequencyResponse or the path of a MIMO FRF CSV (as
    `measure frf --mimo --out` writes). The JSON the command prints (without
    its file and text): per pair "yI<-uJ" the coupling |G_ij| / |G_jj| in dB
    (low_frequency_db over low_frequency_lines_Hz, max_db at max_Hz), the
    static gain G0, its 1-norm condition, the output matrix
    D = G0^-1 diag(G0), the coupling left after it (after_static_db,
    after_lines). below_hz: the low-frequency lines are those at or below it
    (default the lowest 3)."""
    if isinstance(response, MimoFrequencyResponse):
        f_hz, g = response.frequency_hz, response.response
    elif isinstance(response, (str, os.PathLike)):
        e = _piezoloop.load_mimo_frf(os.fspath(response))
        f_hz, g = e["frequency_Hz"], e["response"]
    else:
        raise TypeError(f"response: a MimoFrequencyResponse or a CSV path, got {type(response).__name__}")
    g = np.asarray(g, dtype=complex)
    if g.ndim != 3:
        raise ValueError(f"response: must be lines x n x n, got shape {g.shape}")
    return _piezoloop.analyze_coupling(numbers("frequency_hz", f_hz), g,
                                       None if below_hz is None else number("below_hz", below_hz))
