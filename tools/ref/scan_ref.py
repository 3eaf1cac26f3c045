#!/usr/bin/python3
"""Scan patterns computed independently of common/piezoloop/scan/ (reference
for tests/common/scan/): positions in double precision (numpy), events from
exact rational arithmetic. Run with Debian's /usr/bin/python3; writes
tests/golden/scan_ref.json.

Raster and cycloid: the line sweep's velocity profile (constant velocity,
turnarounds v_in + (v_out - v_in)(3x^2 - 2x^3)) integrated tick by tick with
Simpson's rule (exact for a cubic velocity), not the closed-form integral
the generator uses; the staircase steps along 10x^3 - 15x^4 + 6x^5. The
sine raster: x = -A cos(pi k / half) with numpy's cos and arccos.
Spiral: r = R theta / (2 pi K) with theta linear in time (CAV) or
theta^2 linear in time past the centre region (CLV). Lissajous: the closed
form with phases n f / f_s as exact fractions, and the share of a 64 x 64
grid it visits in a frame. The tick counts follow the rounding rules that
docs/scan.md states (round half up, whole pixels of whole ticks).
"""
import json
import math
import os
from fractions import Fraction

import numpy as np


def f32(v):
    """The value as the generator's float field holds it."""
    return float(np.float32(v))


def rhu(v):
    return math.floor(v + 0.5)


def smooth(x):
    return x * x * (3.0 - 2.0 * x)


def min_jerk(x):
    return x ** 3 * (10.0 - 15.0 * x + 6.0 * x * x)


# ---- raster and cycloid --------------------------------------------------------


def sweep_layout(c):
    fs = f32(c["sample_rate_Hz"])
    P, L = c["pixels_per_line"], c["lines_per_frame"]
    if c["pattern"] == "raster":
        bi = c["bidirectional"]
        turn = rhu(f32(c["turnaround_s"]) * fs)
        k, o = f32(c["retrace_speed_factor"]), f32(c["overscan_fraction"])
        line = fs / f32(c["line_rate_Hz"])
        # line = cv + turn, or cv + retrace + 2 turn with v_t (cv + turn) = k v_t (retrace + turn)
        budget = line - turn if bi else line / (1 + 1 / k) - turn
        used = rhu(budget / (1 + 2 * o) / P) * P
        over = rhu(o * used)
        cv = used + 2 * over
        retrace = 0 if bi else rhu((cv + turn) / k - turn)
        slow = c["slow_axis"]
    else:  # cycloid
        bi = True
        turn = rhu(fs / f32(c["turn_rate_Hz"]))
        cv = turn * c["turns_per_line"]
        used, over, retrace, slow = cv, 0, 0, "staircase"
    vt = f32(c["size_x_um"]) / used
    vr = vt * (cv + turn) / (retrace + turn) if not bi else vt
    line_ticks = cv + turn if bi else cv + retrace + 2 * turn
    return dict(turn=turn, cv=cv, used=used, over=over, retrace=retrace, bi=bi, slow=slow,
                vt=vt, vr=vr, line_ticks=line_ticks, frame_ticks=line_ticks * L, P=P, L=L)


def integrate_segment(x0, n, v_in, v_out):
    """Positions at ticks 0..n-1 of a segment and its end, by Simpson's rule per tick."""
    t = np.arange(n, dtype=float)
    v = lambda tau: v_in + (v_out - v_in) * smooth(tau / n)
    steps = (v(t) + 4 * v(t + 0.5) + v(t + 1)) / 6
    pos = x0 + np.concatenate(([0.0], np.cumsum(steps)))
    return pos[:-1], pos[-1]


def sine_sweep(c):
    """The raster with a sine fast axis: x = -A cos(pi k / half) a sweep."""
    fs = f32(c["sample_rate_Hz"])
    P, L, frames, bi = c["pixels_per_line"], c["lines_per_frame"], c["frames"], c["bidirectional"]
    W, H, o = f32(c["size_x_um"]), f32(c["size_y_um"]), f32(c["overscan_fraction"])
    line = fs / f32(c["line_rate_Hz"])
    half = rhu(line if bi else line / 2)
    A = W / 2 * (1 + 2 * o)
    k1 = rhu(half * math.acos(1 / (1 + 2 * o)) / math.pi)
    used = half - 2 * k1
    line_ticks = half if bi else 2 * half
    frame_ticks = line_ticks * L
    k = np.arange(line_ticks, dtype=float)
    xs, ys = [], []
    events = {"frame": [], "line": [], "pixel": []}
    stair = lambda f, i: -H / 2 + (i if f % 2 == 0 else L - 1 - i) * H / (L - 1) if L > 1 else 0.0
    step_from, step_len = (k1 + used, k1) if bi else (half, half)
    count = 0
    for f in range(frames):
        for i in range(L):
            tick = f * frame_ticks + i * line_ticks
            events["line"].append(tick)
            if i == 0:
                events["frame"].append(tick)
            events["pixel"] += [tick + k1 + -(-j * used // P) for j in range(P)]
            sign = -1.0 if bi and count % 2 == 1 else 1.0
            xs.append(-sign * A * np.cos(np.pi * k / half))
            if c["slow_axis"] == "ramp":
                frac = (i * line_ticks + k) / frame_ticks
                ys.append(-H / 2 + H * frac if f % 2 == 0 else H / 2 - H * frac)
            else:
                y = np.full(line_ticks, stair(f, i))
                if i + 1 < L:
                    m = k >= step_from
                    y[m] += (stair(f, i + 1) - stair(f, i)) * min_jerk((k[m] - step_from) / step_len)
                ys.append(y)
            count += 1
    derived = {"half": half, "overscan": k1, "used": used, "line_ticks": line_ticks, "frame_ticks": frame_ticks,
               "amplitude_um": A}
    return np.concatenate(xs), np.concatenate(ys), events, derived


def sweep(c):
    if c.get("fast_axis") == "sine":
        return sine_sweep(c)
    g = sweep_layout(c)
    frames, L, H = c["frames"], g["L"], f32(c["size_y_um"])
    turn, vt, vr = g["turn"], g["vt"], g["vr"]
    xs, ys = [], []
    events = {"frame": [], "line": [], "pixel": []}
    x = -vt * g["cv"] / 2 - vt * turn / 2
    seg_x, x = integrate_segment(x, turn, 0.0, vt)  # lead-in
    xs.append(seg_x)
    ys.append(np.full(turn, -H / 2))
    tick = turn
    stair = lambda f, i: -H / 2 + (i if f % 2 == 0 else L - 1 - i) * H / (L - 1) if L > 1 else 0.0
    line_count = 0
    for f in range(frames):
        for i in range(L):
            events["line"].append(tick)
            if i == 0:
                events["frame"].append(tick)
            for j in range(g["P"]):
                events["pixel"].append(tick + g["over"] + -(-j * g["used"] // g["P"]))
            sign = -1.0 if (g["bi"] and line_count % 2 == 1) else 1.0
            if g["bi"]:
                segs = [(g["cv"], sign * vt, sign * vt, False), (turn, sign * vt, -sign * vt, True)]
            else:
                segs = [(g["cv"], vt, vt, False), (turn, vt, -vr, False), (g["retrace"], -vr, -vr, False),
                        (turn, -vr, vt, True)]
            last = f == frames - 1 and i == L - 1
            t_line = 0
            for s, (n, v_in, v_out, step) in enumerate(segs):
                if last and s == len(segs) - 1:
                    v_out = 0.0  # the lead-out
                seg_x, x = integrate_segment(x, n, v_in, v_out)
                xs.append(seg_x)
                k = np.arange(n, dtype=float)
                if g["slow"] == "ramp":
                    t = i * g["line_ticks"] + t_line + k
                    frac = t / g["frame_ticks"]
                    y = -H / 2 + H * frac if f % 2 == 0 else H / 2 - H * frac
                else:
                    y = np.full(n, stair(f, i))
                    if step and i + 1 < L:
                        y = y + (stair(f, i + 1) - stair(f, i)) * min_jerk(k / n)
                ys.append(y)
                t_line += n
            tick += g["line_ticks"]
            line_count += 1
    x, y = np.concatenate(xs), np.concatenate(ys)
    if c["pattern"] == "cycloid":
        r, n = f32(c["radius_um"]), np.arange(len(x), dtype=float)
        x = x + r * np.cos(2 * np.pi * n / turn)
        y = y + r * np.sin(2 * np.pi * n / turn)
    derived = {k: g[k] for k in ("turn", "cv", "used", "over", "retrace", "line_ticks", "frame_ticks")}
    derived["v_trace_um_per_tick"] = vt
    derived["v_retrace_um_per_tick"] = vr
    return x, y, events, derived


# ---- spiral ------------------------------------------------------------------------


def spiral(c):
    fs = f32(c["sample_rate_Hz"])
    R, K, P = f32(c["radius_um"]), c["turns"], c["pixels_per_line"]
    N = rhu(fs / f32(c["turn_rate_Hz"]))
    derived = {"turn_ticks": N}
    if c["spiral_mode"] == "cav":
        n_c = n_out = K * N
        theta = lambda n: n / N  # turns
    else:
        f_turn = fs / N
        r_c = f32(c["linear_speed_um_s"]) / (2 * math.pi * f_turn)
        n_c = rhu(r_c / R * K * N)
        th_c = n_c / N
        v = 2 * math.pi * f_turn * R * th_c / K
        n_out = n_c + rhu(fs * math.pi * R * (K * K - th_c * th_c) / (K * v))
        q_c = th_c / K

        def theta(n):
            q = np.sqrt(np.maximum(q_c ** 2 + (1 - q_c ** 2) * (n - n_c) / (n_out - n_c), 0.0))
            return np.where(n < n_c, n / N, K * q)

        derived["clv_speed_um_s"] = v
    derived.update(centre_ticks=n_c, out_ticks=n_out, frame_ticks=2 * n_out)
    n = np.arange(2 * n_out, dtype=float)
    m = np.where(n < n_out, n, 2 * n_out - n)
    th = theta(m)
    r = R * th / K
    x = r * np.cos(2 * np.pi * th)
    y = np.where(n < n_out, 1.0, -1.0) * r * np.sin(2 * np.pi * th)
    frames = c["frames"]
    x, y = np.tile(x, frames), np.tile(y, frames)
    events = {"frame": [f * 2 * n_out for f in range(frames)], "line": [], "pixel": []}
    if c["spiral_mode"] == "cav":
        for f in range(frames):
            for t in range(K):
                base = f * 2 * n_out + t * N
                events["line"].append(base)
                events["pixel"] += [base + -(-j * N // P) for j in range(P)]
    return x, y, events, derived


# ---- Lissajous ----------------------------------------------------------------------


def lissajous(c):
    fs = int(c["sample_rate_Hz"])
    rx, ry = Fraction(int(c["frequency_x_Hz"]), fs), Fraction(int(c["frequency_y_Hz"]), fs)
    frame = math.lcm(rx.denominator, ry.denominator)
    A, B = f32(c["size_x_um"]) / 2, f32(c["size_y_um"]) / 2
    phi = f32(c["phase_y_deg"]) / 360.0
    n = np.arange(frame, dtype=np.int64)
    px = (n * rx.numerator % rx.denominator) / rx.denominator
    py = (n * ry.numerator % ry.denominator) / ry.denominator
    x = A * np.sin(2 * np.pi * px)
    y = B * np.sin(2 * np.pi * (py + phi))
    # Pixel count from the phase rounded up to 2^-32 cycle (exact integers).
    P = c["pixels_per_line"]
    two32 = 1 << 32
    num, den = rx.numerator, rx.denominator

    def pixel(k):
        ph = -(-((k * num) % den) * two32 // den) % two32
        return ((ph + (1 << 30)) % two32) * 2 * P >> 32

    events = {"frame": [0], "line": [], "pixel": []}
    last = pixel(frame - 1)
    for k in range(frame):
        p = pixel(k)
        if p != last:
            events["pixel"].append(k)
            if p % P == 0:
                events["line"].append(k)
        last = p
    G = 64
    ix = np.clip(np.floor((x + A) / (2 * A) * G), 0, G - 1).astype(int)
    iy = np.clip(np.floor((y + B) / (2 * B) * G), 0, G - 1).astype(int)
    coverage = len(set(zip(ix.tolist(), iy.tolist()))) / (G * G)
    derived = {"frame_ticks": frame, "cycles_x": int(rx * frame), "coverage_grid": G, "coverage": coverage,
               "pixel_events": len(events["pixel"])}
    events["pixel"] = events["pixel"][:200]
    return x, y, events, derived


# ---- cases -----------------------------------------------------------------------------

BASE = {"sample_rate_Hz": 100000.0, "centre_x_um": 0.0, "centre_y_um": 0.0, "rotation_deg": 0.0, "frames": 1}
CASES = [
    ("raster_unidirectional_staircase", 11, dict(
        pattern="raster", size_x_um=10.0, size_y_um=8.0, line_rate_Hz=200.0, retrace_speed_factor=2.0,
        overscan_fraction=0.1, turnaround_s=0.0005, pixels_per_line=16, lines_per_frame=6, frames=2,
        slow_axis="staircase", bidirectional=False)),
    ("raster_bidirectional_ramp_rotated", 11, dict(
        pattern="raster", size_x_um=10.0, size_y_um=8.0, line_rate_Hz=200.0, retrace_speed_factor=1.0,
        overscan_fraction=0.05, turnaround_s=0.0005, pixels_per_line=16, lines_per_frame=5, frames=2,
        slow_axis="ramp", bidirectional=True, rotation_deg=30.0, centre_x_um=3.0, centre_y_um=-2.0)),
    ("raster_sine_unidirectional_staircase", 11, dict(
        pattern="raster", fast_axis="sine", size_x_um=10.0, size_y_um=8.0, line_rate_Hz=200.0,
        overscan_fraction=0.1, pixels_per_line=16, lines_per_frame=4, frames=2, slow_axis="staircase",
        bidirectional=False)),
    ("raster_sine_bidirectional_staircase_rotated", 11, dict(
        pattern="raster", fast_axis="sine", size_x_um=10.0, size_y_um=8.0, line_rate_Hz=200.0,
        overscan_fraction=0.1, pixels_per_line=16, lines_per_frame=5, frames=2, slow_axis="staircase",
        bidirectional=True, rotation_deg=-20.0, centre_x_um=-1.0, centre_y_um=2.0)),
    ("cycloid", 11, dict(
        pattern="cycloid", size_x_um=6.0, size_y_um=4.0, radius_um=0.5, turn_rate_Hz=1000.0, turns_per_line=12,
        pixels_per_line=24, lines_per_frame=4, frames=1)),
    ("spiral_cav", 29, dict(
        pattern="spiral", spiral_mode="cav", radius_um=5.0, turns=6, turn_rate_Hz=200.0, pixels_per_line=32,
        frames=2)),
    ("spiral_clv", 29, dict(
        pattern="spiral", spiral_mode="clv", radius_um=5.0, turns=8, turn_rate_Hz=400.0,
        linear_speed_um_s=2000.0, pixels_per_line=16, frames=1)),
    ("lissajous", 211, dict(
        pattern="lissajous", size_x_um=8.0, size_y_um=6.0, frequency_x_Hz=23.0, frequency_y_Hz=19.0,
        phase_y_deg=90.0, pixels_per_line=40, frames=1)),
]


def main():
    out = []
    for name, stride, fields in CASES:
        c = dict(BASE, **fields)
        run = {"raster": sweep, "cycloid": sweep, "spiral": spiral, "lissajous": lissajous}[c["pattern"]]
        x, y, events, derived = run(c)
        th = math.radians(f32(c["rotation_deg"]))
        cx, cy = f32(c["centre_x_um"]), f32(c["centre_y_um"])
        xr = cx + math.cos(th) * x - math.sin(th) * y
        yr = cy + math.sin(th) * x + math.cos(th) * y
        out.append({"name": name, "config": c, "derived": derived, "ticks": len(x), "stride": stride,
                    "x_um": [float(v) for v in xr[::stride]], "y_um": [float(v) for v in yr[::stride]],
                    "events": events})
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "golden", "scan_ref.json")
    with open(path, "w") as f:
        json.dump({"cases": out}, f, separators=(",", ":"))
        f.write("\n")


if __name__ == "__main__":
    main()
