"""piezoloop.scan: a scan on the simulator's stage of coupled axes, as
`piezoloop scan` (docs/scan.md)."""
from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Dict, Optional, Sequence

import numpy as np

from . import _piezoloop
from ._args import number, numbers, path, text, whole


@dataclass
class ScanImage:
    """An image of the scan's last frame with pixels: values is ny x nx (row
    j is y, column i is x; NaN where no pixel fell), extent_um the cell
    edges [x_min, x_max, y_min, y_max] (matplotlib's imshow extent with
    origin="lower"), unit "height (nm)" or "um"."""
    values: np.ndarray
    extent_um: list
    title: str
    unit: str


@dataclass
class ScanResult:
    """A scan.

    ticks: numpy arrays, one row a tick from the scan's first tick (the
        columns of `piezoloop scan`'s scan.csv): commanded_x_um,
        commanded_y_um, measured_x_um, measured_y_um, true_x_um, true_y_um,
        height_nm, sync (bit 0 frame, bit 1 line, bit 2 pixel clock).
    images: "image_commanded", "image_measured" (the probe's height placed
        at commanded and at measured positions), "error_x", "error_y"
        (commanded - measured, um); empty if the scan made no image
        (figures["images_skipped"] says why).
    figures: the JSON `piezoloop scan` prints (tracking in um and % of the
        size, used fraction, linearity, frame time, the grating's pitch).
    """
    ticks: Dict[str, np.ndarray]
    images: Dict[str, ScanImage]
    figures: dict


def _pair(name: str, value, default) -> tuple:
    if value is None:
        return default
    v = numbers(name, value)
    if len(v) != 2:
        raise ValueError(f"{name}: two numbers (x, y), got {len(v)}")
    return v[0], v[1]


def scan(scenario: str | os.PathLike, case: Optional[str] = None, pattern: str = "raster", *,
         size_um: Sequence[float] = (20.0, 20.0), pixels: Sequence[int] = (256, 256), line_rate_hz: float = 50.0,
         retrace_speed: float = 1.0, frames: int = 1, sample: str = "grating:pitch=2,height_nm=50",
         centre_um: Optional[Sequence[float]] = None) -> ScanResult:
    """Scan `frames` frames of `pattern` ("raster", "spiral", "lissajous",
    "cycloid") on the scenario's stage of two or three axes with its case
    `case` (default its first), over the emulated `sample` ("grating:pitch=2,
    height_nm=50,duty=0.5", "step:x=50,height_nm=50", "dots:pitch=2,
    radius=0.5,height_nm=20"). size_um (W, H), pixels (NX, NY) and
    line_rate_hz (lines a second; spiral: turns a second) as the command
    line's --size-um, --pixels and --line-rate-hz; retrace_speed (raster:
    the retrace's speed over the trace's, 1 to 16) as --retrace-speed; centre_um (X, Y), default
    the middle of each axis's travel. A request the scan cannot make (beyond
    an axis's travel, a line rate the loop cannot follow, ...) raises
    ValueError naming the argument. The GIL is released while it runs."""
    args = scan_args(pattern, size_um, pixels, line_rate_hz, retrace_speed, frames, sample, centre_um)
    return scan_result(_piezoloop.scan(path("scenario", scenario), text("case", case, True), *args))


def scan_args(pattern, size_um, pixels, line_rate_hz, retrace_speed, frames, sample, centre_um) -> tuple:
    """The request's arguments checked, in the binding's order (pattern,
    W, H, NX, NY, line rate, retrace speed, frames, sample, centre)."""
    w, h = _pair("size_um", size_um, (20.0, 20.0))
    px = pixels if pixels is not None else (256, 256)
    if isinstance(px, (str, bytes)) or not hasattr(px, "__len__") or len(px) != 2:
        raise TypeError(f"pixels: two whole numbers (NX, NY), got {pixels!r}")
    nx, ny = whole("pixels[0]", px[0]), whole("pixels[1]", px[1])
    centre = None if centre_um is None else _pair("centre_um", centre_um, None)
    return (text("pattern", pattern), w, h, nx, ny, number("line_rate_hz", line_rate_hz),
            number("retrace_speed", retrace_speed), whole("frames", frames), text("sample", sample), centre)


def scan_result(r: dict) -> ScanResult:
    """The binding's {ticks, images, figures} as a ScanResult."""
    images = {k: ScanImage(values=v["values"], extent_um=list(v["extent_um"]), title=v["title"], unit=v["unit"])
              for k, v in r["images"].items()}
    return ScanResult(ticks=dict(r["ticks"]), images=images, figures=r["figures"])
