# Type stubs of the piezoloop package (docs/python.md). Units are in the
# names: _um micrometres, _V volts, _s seconds, _hz hertz.
import os
from dataclasses import dataclass
from typing import Callable, Dict, Literal, Mapping, Optional, Sequence, Union, overload

import numpy as np

from . import design as design

PathLike = Union[str, os.PathLike]

class LinkError(Exception):
    """The board cannot be reached, or the link failed."""

class DeviceError(LinkError):
    """The board refused a request; the message names group.field."""

@dataclass
class SimRun:
    signals: Dict[str, np.ndarray]  # tick, t_s, r_um, y_um, e_um, u_V, u_ff_V, u_fb_V, v_piezo_V, x_um
                                    # (coupled axes: tick, t_s, per axis A r_A_um, y_A_um, u_A_V, p_A_um)
    metrics: dict                   # the JSON `piezoloop sim` prints (coupled axes: axes, cross_motion_pct)
    log_hash: str                   # as `piezoloop sim --hash`

def sim(scenario: PathLike, case: str, trajectory: str = "triangle", frequency_hz: float = 10.0,
        amplitude_um: Optional[float] = None, duration_s: Optional[float] = None, sample: Optional[str] = None,
        fidelity: str = "float", *, amplitude_v: Optional[float] = None, offset: Optional[str] = None,
        substeps: int = 10, log_every: int = 0, midpoint_um: Optional[float] = None, axis: Optional[str] = None,
        hold_um: Union[None, float, Mapping[str, float]] = None) -> SimRun: ...

@dataclass
class ScanImage:
    values: np.ndarray      # ny x nx (row j is y); NaN where no pixel fell
    extent_um: list         # cell edges [x_min, x_max, y_min, y_max]
    title: str
    unit: str               # "height (nm)" or "um"

@dataclass
class ScanResult:
    ticks: Dict[str, np.ndarray]   # commanded_/measured_/true_x_um, _y_um, height_nm, sync (a row a tick)
    images: Dict[str, ScanImage]   # image_commanded, image_measured, error_x, error_y
    figures: dict                  # the JSON `piezoloop scan` prints

def scan(scenario: PathLike, case: Optional[str] = None, pattern: str = "raster", *,
         size_um: Sequence[float] = (20.0, 20.0), pixels: Sequence[int] = (256, 256), line_rate_hz: float = 50.0,
         retrace_speed: float = 1.0, frames: int = 1, sample: str = "grating:pitch=2,height_nm=50",
         centre_um: Optional[Sequence[float]] = None) -> ScanResult: ...

@dataclass
class FrequencyResponse:
    frequency_hz: np.ndarray             # the excited lines, Hz
    response: np.ndarray                 # complex G, um/V
    std_db: np.ndarray                   # one standard deviation of |G| in dB (nan with one period)
    coherence: Optional[np.ndarray]      # sweep, prbs
    sensitivity: Optional[np.ndarray]    # closed loop: complex S = U / D (T = 1 - S)
    report: dict                         # the JSON `piezoloop measure frf --out` writes
    @property
    def log_hash(self) -> str: ...
    @property
    def warnings(self) -> list: ...
    def save(self, path: PathLike) -> None: ...

@dataclass
class MimoFrequencyResponse:
    frequency_hz: np.ndarray  # the excited lines (L), Hz
    response: np.ndarray      # complex, L x n x n: [k, i, j] is y_i <- u_j, um/V
    std: np.ndarray           # L x n x n, one standard deviation of each element (nan with one period)
    snr_db: np.ndarray        # L x n x n
    axes: list                # the axes' names, in the matrices' order
    report: dict              # the JSON `piezoloop measure frf --mimo` prints
    @property
    def log_hash(self) -> str: ...
    def save_csv(self, path: PathLike) -> None: ...

@overload
def measure_frf(scenario: PathLike, from_hz: float, to_hz: float, amplitude_v: float, *, bias_v: float = 0.0,
                mode: str = "open", signal: str = "multisine", periods: int = 10, transient_periods: int = 1,
                case: Optional[str] = None, sample: Optional[str] = None,
                mimo: Literal[False] = False) -> FrequencyResponse: ...
@overload
def measure_frf(scenario: PathLike, from_hz: float, to_hz: float, amplitude_v: float, *, bias_v: float = 0.0,
                mode: str = "open", signal: str = "multisine", periods: int = 10, transient_periods: int = 1,
                case: None = None, sample: None = None, mimo: Literal[True],
                output_matrix: Union[None, Sequence[Sequence[float]], np.ndarray] = None) -> MimoFrequencyResponse: ...

def analyze_coupling(response: Union[MimoFrequencyResponse, PathLike], *,
                     below_hz: Optional[float] = None) -> dict: ...

@dataclass
class StepResponse:
    time_s: np.ndarray        # s, 0 at the step's tick
    reference_um: np.ndarray
    command_v: np.ndarray     # V, after the limiter
    response_um: np.ndarray
    figures: dict             # overshoot_pct, rise_time_s, settling_time_s, initial_um, final_value_um, ...
    report: dict              # the JSON `piezoloop measure step --out` writes
    @property
    def log_hash(self) -> str: ...
    def save(self, path: PathLike) -> None: ...

def measure_step(scenario: PathLike, *, step_um: Optional[float] = None, step_v: Optional[float] = None,
                 from_um: Optional[float] = None, bias_v: Optional[float] = None, duration_s: float = 0.1,
                 mode: Optional[str] = None, case: Optional[str] = None,
                 sample: Optional[str] = None) -> StepResponse: ...

@dataclass
class Loops:
    time_s: np.ndarray
    command_v: np.ndarray     # V, after the limiter
    response_um: np.ndarray   # um, read at the next tick
    amplitude_v: np.ndarray   # the loop each sample belongs to
    loops: list               # per amplitude: hysteresis_pct, max_width_pct, y_min_um, y_max_um
    report: dict              # the summary `piezoloop measure loops --json` writes
    def save_csv(self, path: PathLike) -> None: ...

def measure_loops(scenario: PathLike, amplitudes_v: Sequence[float], *, bias_v: Optional[float] = None,
                  frequency_hz: float = 1.0, cycles: int = 2, shape: str = "triangle", case: Optional[str] = None,
                  sample: Optional[str] = None) -> Loops: ...

def commission(scenario: PathLike, range_um: float, out: PathLike, *, target_bandwidth_hz: Optional[float] = None,
               progress: Optional[Callable[[str], None]] = None) -> dict: ...

@dataclass
class Recording:
    signals: Dict[str, np.ndarray]  # t_s and r_um, y_um, e_um, u_V, u_ff_V, u_fb_V, u_rc_V as recorded
    summary: dict                   # the JSON `piezoloop record` prints
    log_hash: str
    lost_blocks: int
    @property
    def complete(self) -> bool: ...

class Device:
    def __init__(self, address: str, timeout_s: float = 3.0) -> None: ...
    def __enter__(self) -> "Device": ...
    def __exit__(self, *exc: object) -> None: ...
    def close(self) -> None: ...
    @property
    def address(self) -> str: ...
    def status(self) -> dict: ...
    def get(self, group: str, *, axis: Optional[str] = None) -> dict: ...
    def set(self, group: str, *, axis: Optional[str] = None, **fields: object) -> dict: ...
    def set_scenario(self, scenario: PathLike, case: str, frequency_hz: float = 0.0) -> dict: ...
    def arm(self) -> None: ...
    def disarm(self) -> None: ...
    def clear_trip(self) -> None: ...
    def save(self) -> None: ...
    def load(self) -> None: ...
    def forget(self) -> None: ...
    def record(self, duration_s: float, signals: Union[str, Sequence[str]] = "r,y,e,u", *, start_wave: bool = False,
               restart_stage: bool = False, trajectory: Optional[str] = None, frequency_hz: float = 10.0,
               amplitude_um: Optional[float] = None, offset: Optional[str] = None,
               scenario: Optional[PathLike] = None, cycles: int = 0, decimation: int = 1,
               stall_s: float = 5.0, out_csv: Optional[PathLike] = None, axis: Optional[str] = None,
               every_axis: bool = False) -> Recording: ...
    def measure_frf(self, from_hz: float, to_hz: float, amplitude_v: float, *, bias_v: float = 0.0,
                    mode: str = "open", signal: str = "multisine", periods: int = 10, transient_periods: int = 1,
                    restart_stage: bool = False, axis: Optional[str] = None,
                    mimo: bool = False) -> Union[FrequencyResponse, MimoFrequencyResponse]: ...
    def measure_step(self, *, step_um: Optional[float] = None, step_v: Optional[float] = None,
                     from_um: Optional[float] = None, bias_v: Optional[float] = None, duration_s: float = 0.1,
                     mode: Optional[str] = None, restart_stage: bool = False,
                     axis: Optional[str] = None) -> StepResponse: ...
    def measure_loops(self, amplitudes_v: Sequence[float], *, bias_v: Optional[float] = None,
                      frequency_hz: float = 1.0, cycles: int = 2, shape: str = "triangle",
                      restart_stage: bool = False, axis: Optional[str] = None) -> Loops: ...
    def commission(self, range_um: float, out: PathLike, *, target_bandwidth_hz: Optional[float] = None,
                   save: bool = True, progress: Optional[Callable[[str], None]] = None,
                   axis: Optional[str] = None) -> dict: ...
    def wave(self, trajectory: str = "triangle", frequency_hz: float = 10.0, amplitude_um: float = 0.0, *,
             offset: Optional[str] = None, scenario: Optional[PathLike] = None, cycles: int = 0,
             arm: bool = False, axis: Optional[str] = None) -> dict: ...
    def stop(self) -> dict: ...
    def stream(self, setpoints_um: np.ndarray, prefill: Optional[int] = None) -> dict: ...
    def scan(self, pattern: str = "raster", *, size_um: Sequence[float] = (20.0, 20.0),
             pixels: Sequence[int] = (256, 256), line_rate_hz: float = 50.0, retrace_speed: float = 1.0,
             frames: int = 1, sample: str = "grating:pitch=2,height_nm=50",
             centre_um: Optional[Sequence[float]] = None, scenario: Optional[PathLike] = None,
             restart_stage: bool = False, rc_period_from_scan: bool = False) -> ScanResult: ...

def connect(address: str, timeout_s: float = 3.0) -> Device: ...

def devices() -> list: ...  # [{"device", "serial", "product", "bus_port", "vid_pid"}]

class Emulator:
    address: str
    info: dict
    def close(self) -> None: ...
    def __enter__(self) -> "Emulator": ...
    def __exit__(self, *exc: object) -> None: ...

def emulate(board: str = "qemu-m7", scenario: Optional[PathLike] = None, *, image: Optional[PathLike] = None,
            case: Optional[str] = None, storage: Optional[PathLike] = None) -> Emulator: ...
