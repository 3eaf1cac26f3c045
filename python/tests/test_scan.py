"""piezoloop.scan against `piezoloop scan` on configs/stages/xy_flexure.json:
the same figures and the same ticks (scan.csv), the images checked on their
own (the grating's pitch read off the image at commanded positions by a
Fourier transform, and each error map against the ticks), every pattern
scanning a complete frame, and the refusals naming the argument."""
import csv
import json
import os

import numpy as np
import pytest

import piezoloop
from conftest import CONFIGS, cli

XY = os.path.join(CONFIGS, "stages", "xy_flexure.json")


def test_raster_equals_cli(tmp_path):
    r = piezoloop.scan(XY, "pi_notch", size_um=(20, 20), pixels=(48, 48), line_rate_hz=50)
    out = tmp_path / "raster"
    ref = json.loads(cli("scan", "--scenario", XY, "--case", "pi_notch", "--size-um", "20x20", "--pixels", "48x48",
                         "--line-rate-hz", "50", "--out", str(out)))
    ref.pop("csv")
    assert r.figures == ref
    with open(out / "scan.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(r.ticks["sync"]) == r.figures["ticks"]
    # scan.csv writes 9 significant digits.
    for k, v in r.ticks.items():
        col = np.array([float(row[k]) for row in rows])
        if k == "sync":
            assert np.array_equal(col, v), k
        else:
            assert np.allclose(col, v, rtol=1e-8, atol=1e-9), k


def test_raster_images():
    pitch_um = 2.0
    r = piezoloop.scan(XY, "pi_notch", size_um=(20, 20), pixels=(64, 64), line_rate_hz=50,
                       sample=f"grating:pitch={pitch_um},height_nm=50")
    im = r.images["image_commanded"]
    assert im.values.shape == (64, 64) and im.unit == "height (nm)"
    x0, x1, y0, y1 = im.extent_um
    assert x1 - x0 == pytest.approx(20.0, rel=1e-6)  # 64 cells across the 20 um line
    # The grating's lines run along y: every row shows its period, 10 periods
    # in the 20 um line; the strongest non-zero Fourier line of the mean row
    # is at 20 / pitch cycles per line width (one bin: 64 / 63 of it).
    row = np.nanmean(im.values, axis=0)
    spectrum = np.abs(np.fft.rfft(row - row.mean()))
    cycles = np.argmax(spectrum[1:]) + 1
    assert abs(cycles - (x1 - x0) / pitch_um) <= 1.0, cycles
    # The error maps hold commanded - measured: their spread and extreme
    # agree with the ticks' over the pixels (tracking figures); every cell
    # is within the largest tick error.
    for axis in ("x", "y"):
        e = r.images[f"error_{axis}"].values
        assert np.all(np.isfinite(e))
        worst = r.figures["tracking"][f"max_{axis}_um"]
        assert np.max(np.abs(e)) <= worst * (1 + 1e-9)
        assert np.sqrt(np.mean(e ** 2)) == pytest.approx(r.figures["tracking"][f"rms_{axis}_um"], rel=0.25)


@pytest.mark.parametrize("pattern", ["spiral", "lissajous", "cycloid"])
def test_patterns_complete_a_frame(pattern):
    r = piezoloop.scan(XY, "pi_notch", pattern, size_um=(16, 16), pixels=(32, 32), line_rate_hz=50)
    f = r.figures
    assert f["complete"] and f["frames_completed"] == 1 and f["pattern"] == pattern
    assert f["pixels"] > 0 and len(r.ticks["sync"]) == f["ticks"]
    # Every pixel is taken within the reported scan area about its centre
    # (lead-ins and retraces may leave it: they are no pixels).
    cx, cy = f["centre_um"]
    w, h = f["size_um"]
    pixel = (r.ticks["sync"] & 4) > 0
    assert np.max(np.abs(r.ticks["commanded_x_um"][pixel] - cx)) <= w / 2 + 1e-3
    assert np.max(np.abs(r.ticks["commanded_y_um"][pixel] - cy)) <= h / 2 + 1e-3
    # Tracking well below the mode: the error under 5 % of the size.
    assert f["tracking"]["rms_x_percent"] < 5 and f["tracking"]["rms_y_percent"] < 5
    assert set(r.images) == {"image_commanded", "image_measured", "error_x", "error_y"}


@pytest.mark.parametrize("kwargs, name, error", [
    (dict(size_um=(200, 200)), "size_um", ValueError),
    (dict(size_um=(20,)), "size_um", ValueError),
    (dict(pixels=(1, 64)), "pixels", ValueError),
    (dict(pixels=(2.5, 64)), "pixels", TypeError),
    (dict(pattern="zigzag"), "pattern", ValueError),
    (dict(case="nope"), "case", ValueError),
    (dict(frames=0), "frames", ValueError),
    (dict(retrace_speed=20), "retrace_speed", ValueError),
    (dict(line_rate_hz=6000), "line_rate_hz", ValueError),
    (dict(sample="ruler:pitch=2"), "sample", ValueError),
    (dict(centre_um=(5, 50)), "centre_um", ValueError),
])
def test_refusals_name_the_argument(kwargs, name, error):
    args = dict(case="pi_notch", pixels=(32, 32))
    args.update(kwargs)
    with pytest.raises(error, match=name):
        piezoloop.scan(XY, **args)


def test_single_axis_scenario_refused():
    with pytest.raises(ValueError, match="scenario"):
        piezoloop.scan(os.path.join(CONFIGS, "ahmad2020.json"))
