"""piezoloop.connect: a board over the link, as `piezoloop --device ADDR ...`."""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Callable, Dict, Optional, Sequence

import numpy as np

from . import _piezoloop
from ._args import finite_json, names, number, numbers, path, text, whole
from .commission import check_commission
from .scan import ScanResult, scan_args, scan_result
from .measure import (FrequencyResponse, Loops, MimoFrequencyResponse, StepResponse, check_request, check_shape,
                      check_step, loops_from_result, response_from_report, step_from_report)

GROUPS = ("feedforward", "feedback", "rc", "limits", "trajectory", "recorder", "link")
BOARD_GROUPS = ("recorder", "link", "input_matrix", "output_matrix")


@dataclass
class Recording:
    """A record from a board.

    signals: numpy arrays, t_s and one per recorded signal named with its
        unit (r_um, y_um, e_um, u_V, u_ff_V, u_fb_V, u_rc_V).
    summary: the JSON `piezoloop record` prints (frames, loss counters,
        log_hash, tracking figures of the last reference period).
    log_hash: hash of r, y and u ("" unless all three were recorded); equal
        to `piezoloop sim --hash` for a record from rest of the same case.
    lost_blocks: log blocks the host never received.
    """
    signals: Dict[str, np.ndarray]
    summary: dict
    log_hash: str
    lost_blocks: int

    @property
    def complete(self) -> bool:
        return bool(self.summary.get("complete"))


class Device:
    """A connected board. Use as a context manager (closes the link on exit;
    the board keeps running as configured). Every request raises LinkError
    when the board cannot be reached and DeviceError (a LinkError) when it
    refuses, with the message naming the group and field."""

    def __init__(self, address: str, timeout_s: float = 3.0):
        if not isinstance(address, str) or not address:
            raise ValueError("address: e.g. 'tcp:127.0.0.1:4000', 'usb', 'usb:SERIAL' or 'serial:/dev/ttyACM0'")
        timeout_s = number("timeout_s", timeout_s)
        if not 1e-3 <= timeout_s <= 3600:
            raise ValueError(f"timeout_s: must be in [0.001, 3600] s (got {timeout_s})")
        self._dev = _piezoloop.Device(address, round(timeout_s * 1000))

    def __enter__(self) -> "Device":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self._dev.close()

    @property
    def address(self) -> str:
        return self._dev.address()

    def status(self) -> dict:
        """{"device", "hello" (identity, hard limits), "status" (armed, faults, ...)}."""
        return self._dev.status()

    def get(self, group: str, *, axis: Optional[str] = None) -> dict:
        """A parameter group by its schema name (`piezoloop schema`), or "all".
        axis: "x", "y" or "z" on a board of axes (required there for an
        axis's group; the board's groups recorder, link, input_matrix and
        output_matrix take none)."""
        a = text("axis", axis, True) or ""
        if group == "all":
            return {g: self._dev.get(g, "" if g in BOARD_GROUPS else a) for g in GROUPS}
        return self._dev.get(group, a)

    def set(self, group: str, *, axis: Optional[str] = None, **fields) -> dict:
        """Merge `fields` (schema names; nested groups as dicts) onto the
        board's group and send it; returns the group read back. An unknown
        field raises ValueError, a value the board refuses DeviceError, both
        naming the field; the board's group is then unchanged. None is no
        value (leave the field out), NaN no JSON number: both raise
        ValueError naming the field."""
        finite_json(group, fields)
        return self._dev.set(group, json.dumps(fields), text("axis", axis, True) or "")

    def set_scenario(self, scenario: str | os.PathLike, case: str, frequency_hz: float = 0.0) -> dict:
        """Send a scenario case's controller (limits, feedforward, feedback,
        rc) as `piezoloop set --scenario --case` does, limits clipped to the
        board's hard limits (listed in "clipped"). frequency_hz: the
        reference frequency, for a repetitive controller's period "auto".
        Only while disarmed."""
        return self._dev.set_scenario(path("scenario", scenario), text("case", case),
                                      number("frequency_hz", frequency_hz))

    def arm(self) -> None:
        self._dev.arm()

    def disarm(self) -> None:
        self._dev.disarm()

    def clear_trip(self) -> None:
        self._dev.clear_trip()

    def save(self) -> None:
        """Store the board's current parameter set in its storage (the set
        `get("all")` returns); applied at the next boot. Only while
        disarmed, and only on a board with storage (hello capability
        "storage")."""
        self._dev.save()

    def load(self) -> None:
        """Validate the stored set and apply it as a whole; a rejected or
        corrupt set changes nothing (the error names the field). Only while
        disarmed."""
        self._dev.load()

    def forget(self) -> None:
        """Erase the board's storage: the next boot uses the safe default.
        Only while disarmed."""
        self._dev.forget()

    def record(self, duration_s: float, signals: str | Sequence[str] = "r,y,e,u", *, start_wave: bool = False,
               restart_stage: bool = False, trajectory: Optional[str] = None, frequency_hz: float = 10.0,
               amplitude_um: Optional[float] = None, offset: Optional[str] = None,
               scenario: Optional[str | os.PathLike] = None, cycles: int = 0, decimation: int = 1,
               stall_s: float = 5.0, out_csv: Optional[str | os.PathLike] = None, axis: Optional[str] = None,
               every_axis: bool = False) -> Recording:
        """Record `signals` for duration_s seconds of device time, as
        `piezoloop record`: "r,y,u" or ["r", "y", "u"]. With trajectory ("triangle", "sine", "square",
        "raster") and amplitude_um (peak-to-peak, um) the reference wave is
        set first; offset "unipolar"/"bipolar" or the scenario's convention.
        start_wave starts it with the recorder (arming the loop);
        restart_stage starts the emulated stage and the loop from rest (a
        record equal to piezoloop.sim). axis: the axis of the signals, the
        wave and its start on a board of axes; every_axis: start_wave starts
        every axis's wave (as set) at the same tick. Ctrl-C stops the recorder cleanly
        and raises KeyboardInterrupt; the loop stays as it was. A record cut
        short (the board gone or stalled, frames lost) raises LinkError
        saying why, with what arrived as its .recording."""
        wave = None
        if trajectory is not None or amplitude_um is not None:
            wave = self._wave_request(trajectory, frequency_hz, amplitude_um, offset, scenario, cycles)
        r = self._dev.record(names("signals", signals), number("duration_s", duration_s),
                             whole("decimation", decimation), bool(start_wave), bool(restart_stage), wave,
                             number("stall_s", stall_s), os.fspath(out_csv) if out_csv else "",
                             text("axis", axis, True) or "", bool(every_axis))
        s = r["summary"]
        rec = Recording(signals=r["signals"], summary=s, log_hash=s.get("log_hash", ""),
                        lost_blocks=int(s["lost_blocks"]))
        if not rec.complete:
            # The board went away, stalled or lost frames: an exception, as
            # the command line exits non-zero; what arrived is on it.
            err = _piezoloop.LinkError(f"{self.address}: record incomplete: {s.get('incomplete', '')}")
            err.recording = rec
            raise err
        return rec

    def wave(self, trajectory: str = "triangle", frequency_hz: float = 10.0, amplitude_um: float = 0.0, *,
             offset: Optional[str] = None, scenario: Optional[str | os.PathLike] = None, cycles: int = 0,
             arm: bool = False, axis: Optional[str] = None) -> dict:
        """Set the board's reference wave and start it, as `piezoloop wave`:
        trajectory "triangle", "sine", "square" or "raster", amplitude_um the
        peak-to-peak range, offset "unipolar"/"bipolar" or the scenario's
        convention, cycles 0 = forever. It runs on when this session ends
        (stop() stops it). arm: arm the loop at the wave's first tick (it must
        be disarmed). Returns {"trajectory", "wave_running", "armed"}."""
        return self._dev.wave(self._wave_request(trajectory, frequency_hz, amplitude_um, offset, scenario, cycles),
                              bool(arm), text("axis", axis, True) or "")

    def stop(self) -> dict:
        """Stop the running wave and setpoint stream, whoever started them; the
        setpoint holds its last value and the loop stays armed."""
        return self._dev.stop()

    def scan(self, pattern: str = "raster", *, size_um: Sequence[float] = (20.0, 20.0),
             pixels: Sequence[int] = (256, 256), line_rate_hz: float = 50.0, retrace_speed: float = 1.0,
             frames: int = 1, sample: str = "grating:pitch=2,height_nm=50",
             centre_um: Optional[Sequence[float]] = None, scenario: Optional[str | os.PathLike] = None,
             restart_stage: bool = False, rc_period_from_scan: bool = False) -> ScanResult:
        """Scan on a board of two or three axes, as `piezoloop --device ADDR
        scan` (docs/scan.md): the arguments as piezoloop.scan's; the board
        runs the controllers it holds. scenario: the stage the board drives
        (its travel, the default centre); without it centre_um is needed and
        the scan stays within the board's position range. restart_stage: an
        emulated stage and the loop start from rest. rc_period_from_scan:
        x's and y's repetitive controllers, when enabled, set to the scan's
        period first (otherwise figures["rc"] notes a different one). Returns a ScanResult
        whose true_x_um / true_y_um are NaN (a board streams no true
        position; the sample is read at the measured positions). A scan the
        board cannot make raises ValueError naming the argument; a record cut
        short raises the link's error."""
        args = scan_args(pattern, size_um, pixels, line_rate_hz, retrace_speed, frames, sample, centre_um)
        where = "" if scenario is None else path("scenario", scenario)
        return scan_result(self._dev.scan(where, *args, bool(restart_stage), bool(rc_period_from_scan)))

    def stream(self, setpoints_um, prefill: Optional[int] = None) -> dict:
        """Stream setpoints (um, one per loop tick) through the board's FIFO, as
        `piezoloop stream`, until the tick has consumed them all. prefill:
        setpoints buffered before the tick starts (default: the FIFO, or all).
        Every value is checked (finite, within +-1e6 um) before the stream
        starts. Ctrl-C closes the stream on the board (the setpoint holds, the
        loop stays as it was) and raises KeyboardInterrupt."""
        raw = np.asarray(setpoints_um)
        if raw.dtype.kind not in "iuf":
            raise TypeError(f"setpoints_um: numbers (um), got an array of {raw.dtype}")
        sp = raw.astype(np.float32)
        if sp.ndim != 1:
            raise ValueError(f"setpoints_um: a 1-D sequence, one setpoint per tick (got shape {sp.shape})")
        if sp.size == 0:
            raise ValueError("setpoints_um: at least one setpoint")
        return self._dev.stream(sp.tolist(), None if prefill is None else whole("prefill", prefill))

    @staticmethod
    def _wave_request(trajectory, frequency_hz, amplitude_um, offset, scenario, cycles):
        """Checked in C++ (check_wave_request, as the command line's options)."""
        wave = _piezoloop.WaveRequest()
        wave.trajectory = text("trajectory", trajectory, True) or "triangle"
        wave.frequency_Hz = number("frequency_hz", frequency_hz)
        wave.amplitude_um = 0.0 if amplitude_um is None else number("amplitude_um", amplitude_um)
        wave.offset = text("offset", offset, True)
        wave.scenario = path("scenario", scenario) if scenario else ""
        n = whole("cycles", cycles)
        # The command line's --cycles is a u32 (the trajectory group's).
        if not 0 <= n <= 0xFFFFFFFF:
            raise ValueError(f"cycles: must be in [0, 4294967295] periods, 0 = forever (got {cycles})")
        wave.cycles = n
        return wave


    def measure_frf(self, from_hz: float, to_hz: float, amplitude_v: float, *, bias_v: float = 0.0,
                    mode: str = "open", signal: str = "multisine", periods: int = 10, transient_periods: int = 1,
                    restart_stage: bool = False, axis: Optional[str] = None, mimo: bool = False):
        """The board's frequency response, as `piezoloop --device measure frf`:
        the board's excitation recorded tick by tick. Open loop its
        controller groups are set to none for the measurement and put back
        after (the loop left disarmed); closed loop its own controller runs.
        restart_stage: an emulated board's stage starts at rest (the response
        then equals piezoloop.measure_frf's on the same scenario, bit for
        bit). A request beyond the board's limits raises ValueError before
        anything moves; Ctrl-C stops the excitation, puts the groups back and
        raises KeyboardInterrupt. axis: the measured axis of a board of axes
        (the others hold with their own controllers).

        mimo=True on a board of axes: the n x n response, as `piezoloop
        --device ADDR measure frf --mimo` (open loop, one axis at a time,
        bias_v on every axis, through the board's output matrix): a
        MimoFrequencyResponse."""
        if mimo:
            if axis is not None:
                raise ValueError("axis: not with mimo=True (it measures every axis)")
            if restart_stage:
                raise ValueError("restart_stage: not with mimo=True on a board")
            if mode != "open":
                raise ValueError("mode: mimo=True measures open loop only")
            if signal != "multisine":
                raise ValueError("signal: mimo=True uses multisines only")
            r = self._dev.measure_frf_mimo(number("from_hz", from_hz), number("to_hz", to_hz),
                                           number("amplitude_v", amplitude_v), number("bias_v", bias_v),
                                           whole("periods", periods), whole("transient_periods", transient_periods))
            return MimoFrequencyResponse(frequency_hz=r["frequency_Hz"], response=r["response"], std=r["std"],
                                         snr_db=r["snr_db"], axes=list(r["report"]["axes"]), report=r["report"])
        check_request(from_hz, to_hz, amplitude_v, mode, signal)
        report = self._dev.measure_frf(number("from_hz", from_hz), number("to_hz", to_hz),
                                       number("amplitude_v", amplitude_v), number("bias_v", bias_v), mode, signal,
                                       whole("periods", periods), whole("transient_periods", transient_periods),
                                       bool(restart_stage), text("axis", axis, True) or "")
        return response_from_report(report)

    def measure_step(self, *, step_um: Optional[float] = None, step_v: Optional[float] = None,
                     from_um: Optional[float] = None, bias_v: Optional[float] = None, duration_s: float = 0.1,
                     mode: Optional[str] = None, restart_stage: bool = False,
                     axis: Optional[str] = None) -> StepResponse:
        """The board's step response, as `piezoloop --device measure step`:
        open loop (step_v, the controller groups set to none and put back)
        or closed loop (step_um, the board's controller; from the setpoint
        it holds unless from_um). Checked against the board's limits before
        anything moves; Ctrl-C as measure_frf."""
        check_step(step_um, step_v, mode)
        opt = lambda name, v: None if v is None else number(name, v)
        report = self._dev.measure_step(opt("step_um", step_um), opt("step_v", step_v), opt("from_um", from_um),
                                        opt("bias_v", bias_v), mode or "", number("duration_s", duration_s),
                                        bool(restart_stage), text("axis", axis, True) or "")
        return step_from_report(report)

    def measure_loops(self, amplitudes_v: Sequence[float], *, bias_v: Optional[float] = None,
                      frequency_hz: float = 1.0, cycles: int = 2, shape: str = "triangle",
                      restart_stage: bool = False, axis: Optional[str] = None) -> Loops:
        """Open-loop hysteresis loops on the board, as `piezoloop --device
        measure loops` (the controller groups set to none and put back)."""
        check_shape(shape)
        r = self._dev.measure_loops(numbers("amplitudes_v", amplitudes_v),
                                    None if bias_v is None else number("bias_v", bias_v),
                                    number("frequency_hz", frequency_hz), whole("cycles", cycles), shape,
                                    bool(restart_stage), text("axis", axis, True) or "")
        return loops_from_result(r)

    def commission(self, range_um: float, out: str | os.PathLike, *, target_bandwidth_hz: Optional[float] = None,
                   save: bool = True, progress: Optional[Callable[[str], None]] = None,
                   axis: Optional[str] = None) -> dict:
        """Commissions the board's stage from measurements alone, as
        `piezoloop --device commission` (docs/commissioning.md): measured,
        designed, checked on the measured response, loaded, verified on the
        board and, when verified and `save`, saved on the board. Writes the
        report and files to `out`; returns the summary. Ctrl-C stops it with
        the board disarmed. axis: the axis commissioned on a board of axes
        (the others hold with their own controllers)."""
        check_commission(range_um, target_bandwidth_hz)
        return self._dev.commission(float(range_um), float(target_bandwidth_hz or 0.0), path("out", out), bool(save),
                                    progress, text("axis", axis, True) or "")


def devices() -> list:
    """The attached USB boards, as `piezoloop devices`: each a dict with its
    --device address ("usb:SERIAL"), serial, product, bus_port, vid_pid."""
    return _piezoloop.devices()


def connect(address: str, timeout_s: float = 3.0) -> Device:
    """Open a board: "tcp:HOST:PORT", "usb", "usb:SERIAL" or "serial:PATH"."""
    return Device(address, timeout_s)
