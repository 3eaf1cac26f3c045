// The scan generator: one tick at a time, the (x, y) reference of a raster,
// spiral, Lissajous or cycloid scan about a centre, rotated by an angle,
// with the third axis held, and the tick's events as a sync word
// (scan_config.hpp). Meant for the tick's reading-independent half: all
// derived numbers are computed in configure(), a tick costs a few integer
// multiplies (and a table read for a sine or a root).
//
// The patterns (line_sweep.hpp, spiral.hpp, lissajous.hpp) produce (u, v)
// in Q31 of the reach rho: the radius about the centre that holds the whole
// path (the L1 extent |u| + |v| for the raster and the cycloid, the outer
// radius for the spiral, A + B for Lissajous, times 1 + 2^-20). The rotation
// (cos, sin from sine_table.hpp, Q31; exact for 0 degrees) turns (u, v)
// in integers, so the float and the Q31 generator share the path bit for bit
// and differ only by the last step:
//   float:  x = centre_x + rho * u' / 2^31
//   Q31:    x = centre_x / fs_x + (rho / fs_x) * u'      (one Q31 multiply)
// The cycloid adds its circle, r (cos, sin)(2 pi n / N_turn), to the line
// sweep's centre (Yong, Moheimani & Petersen, Nanotechnology 21, 2010).
//
// Start: start_point() is the first tick's reference, so a caller
// approaches it first (approach.hpp) and then starts the clock. The raster
// starts there at rest (a lead-in follows; a sine raster starts at a
// turning point), as does the cycloid's centre; the spiral starts at the
// centre, Lissajous at (0, B sin phi); the circle and the spiral's and
// Lissajous' sinusoids start at their speed.
#pragma once

#include <cstdint>
#include <type_traits>

#include "piezoloop/det_math.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/scan/line_sweep.hpp"
#include "piezoloop/scan/lissajous.hpp"
#include "piezoloop/scan/scan_config.hpp"
#include "piezoloop/scan/spiral.hpp"
#include "piezoloop/sine_table.hpp"
#include "piezoloop/status.hpp"
#include "piezoloop/trajectory.hpp"

namespace piezoloop {

template <class T>
struct ScanPoint {
    T x{}, y{}, z{};
    uint32_t sync = 0;  // kSync* bits of this tick
};

namespace scan_detail {

inline constexpr double kPi = 3.141592653589793238462643383279502884;
inline constexpr double kMaxUm = 1.0e6;
inline constexpr double kMaxTicks = 2147483648.0;  // a frame fits 31 bits
inline constexpr double kReachMargin = 1.0 + 0x1p-20;

constexpr double round_half_up(double v) { return static_cast<double>(static_cast<int64_t>(v + 0.5)); }

constexpr bool in_range(float v, double lo, double hi) {
    return is_finite(v) && static_cast<double>(v) >= lo && static_cast<double>(v) <= hi;
}

// s(x) = 3x^2 - 2x^3 and its integral S(x) = x^3 - x^4 / 2 (line_sweep.hpp).
constexpr double smooth(double x) { return x * x * (3.0 - 2.0 * x); }
constexpr double smooth_integral(double x) { return x * x * x * (1.0 - 0.5 * x); }

// How far a turnaround from v_in > 0 to -v_out < 0 (per tick, over n ticks)
// runs beyond its start: where the velocity is zero, s(x) = v_in / (v_in + v_out).
constexpr double turnaround_excursion(double v_in, double v_out, double n) {
    const double target = v_in / (v_in + v_out);
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        (smooth(mid) < target ? lo : hi) = mid;
    }
    return n * (v_in * lo - (v_in + v_out) * smooth_integral(lo));
}

// acos(c) for c in [0, 1] by bisection on cos(t) = sin(pi/2 - t) from the
// sine table's Taylor series (sine_table.hpp): +, -, *, / only, the same on
// every target.
constexpr double det_acos(double c) {
    double lo = 0.0, hi = kPi / 2.0;
    for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        (sine_detail::sin_series(kPi / 2.0 - mid) > c ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

constexpr uint64_t gcd(uint64_t a, uint64_t b) {
    while (b != 0) { const uint64_t t = a % b; a = b; b = t; }
    return a;
}

// The phase step of a sinusoid at ratio = f / f_s. A frequency within a
// float's rounding of f_s / n (n whole) is taken as f_s / n, so that it
// repeats after n ticks: a float cannot hold most such frequencies exactly,
// and their nearest rational would make a frame of up to 2^31 ticks.
constexpr bool sinusoid_phase_step(double ratio, trajectory_detail::PhaseStep& out) {
    if (ratio > 0x1p-31) {
        const double n = round_half_up(1.0 / ratio);
        const double miss = ratio * n - 1.0;
        if (n >= 2.0 && miss <= 0x1p-23 && miss >= -0x1p-23)
            return trajectory_detail::rational_phase_step(1.0 / n, out);
    }
    return trajectory_detail::rational_phase_step(ratio, out);
}

// Phase of an angle in degrees, 2^32 = a turn.
constexpr uint32_t phase_of_deg(float deg) {
    double cycles = static_cast<double>(deg) / 360.0;
    while (cycles < 0.0) cycles += 1.0;
    const double p = round_half_up(cycles * 4294967296.0);
    return static_cast<uint32_t>(static_cast<uint64_t>(p) & 0xffffffffu);
}

}  // namespace scan_detail

template <class T>
class ScanGenerator {
    static_assert(is_sample_type_v<T>, "ScanGenerator<T>: T is float or Q31");
    static constexpr bool kFloat = std::is_same_v<T, float>;

public:
    // The axes' scales (µm <-> Q31; ignored for float). Until configure()
    // succeeds the output is zero.
    explicit constexpr ScanGenerator(SignalScale x = {}, SignalScale y = {}, SignalScale z = {})
        : scale_x_(x), scale_y_(y), scale_z_(z) {}

    // Validates c (errors name the field, group "scan") and restarts at
    // the first tick. On error nothing changes.
    constexpr Status configure(const ScanConfig& c) { return in_group("scan", configure_fields(c)); }

    // Back to the first tick (the lead-in, frame 0).
    constexpr void restart() {
        sweep_.restart();
        spiral_.restart();
        lissajous_.restart();
        circle_k_ = 0;
    }

    // This tick's reference and events, then one tick on.
    constexpr ScanPoint<T> step() {
        ScanPoint<T> out;
        if (!configured_) return out;
        int64_t u = 0, v = 0;
        switch (cfg_.pattern) {
            case ScanPattern::kRaster:
            case ScanPattern::kCycloid: {
                int64_t x47 = 0, y47 = 0;
                out.sync = sweep_.step(x47, y47);
                if (cfg_.pattern == ScanPattern::kCycloid) {
                    const uint32_t p = trajectory_detail::apply_ramp(circle_ramp_, circle_k_);
                    x47 += (circle_radius_ * sine_q31(p + 0x40000000u)) >> 15;
                    y47 += (circle_radius_ * sine_q31(p)) >> 15;
                    if (++circle_k_ == circle_ticks_) circle_k_ = 0;
                }
                u = (x47 + 0x8000) >> 16;
                v = (y47 + 0x8000) >> 16;
                break;
            }
            case ScanPattern::kSpiral:
                out.sync = spiral_.step(u, v);
                break;
            case ScanPattern::kLissajous:
                out.sync = lissajous_.step(u, v);
                break;
        }
        const int32_t ur = Q31::saturate((cos_ * u - sin_ * v + (int64_t{1} << 30)) >> 31).raw();
        const int32_t vr = Q31::saturate((sin_ * u + cos_ * v + (int64_t{1} << 30)) >> 31).raw();
        if constexpr (kFloat) {
            out.x = centre_x_ + reach_f_ * (static_cast<float>(ur) * 0x1p-31f);
            out.y = centre_y_ + reach_f_ * (static_cast<float>(vr) * 0x1p-31f);
        } else {
            out.x = centre_x_ + reach_x_q_ * Q31::from_raw(ur);
            out.y = centre_y_ + reach_y_q_ * Q31::from_raw(vr);
        }
        out.z = hold_z_;
        return out;
    }

    // The first tick's reference (no state change).
    constexpr ScanPoint<T> start_point() const {
        ScanGenerator g = *this;
        g.restart();
        return g.step();
    }

    constexpr bool configured() const { return configured_; }
    // After the last frame (never with frames = 0); the output then holds.
    constexpr bool done() const {
        switch (cfg_.pattern) {
            case ScanPattern::kSpiral: return spiral_.done();
            case ScanPattern::kLissajous: return lissajous_.done();
            default: return sweep_.done();
        }
    }
    constexpr uint32_t frames_completed() const {
        switch (cfg_.pattern) {
            case ScanPattern::kSpiral: return spiral_.frames_completed();
            case ScanPattern::kLissajous: return lissajous_.frames_completed();
            default: return sweep_.frames_completed();
        }
    }
    constexpr uint32_t frame_period_ticks() const {
        switch (cfg_.pattern) {
            case ScanPattern::kSpiral: return spiral_.frame_ticks();
            case ScanPattern::kLissajous: return lissajous_.frame_ticks();
            default: return sweep_.frame_ticks();
        }
    }
    // Raster, cycloid: ticks a line (each sweep when bidirectional); a CAV
    // spiral: ticks a turn; otherwise 0 (lines of varying length).
    constexpr uint32_t line_period_ticks() const {
        switch (cfg_.pattern) {
            case ScanPattern::kSpiral:
                return cfg_.spiral_mode == SpiralMode::kConstantAngularVelocity ? spiral_params_.turn_ticks : 0u;
            case ScanPattern::kLissajous: return 0;
            default: return sweep_.line_ticks();
        }
    }
    // The period of the fast motion, for a repetitive controller: a line
    // (two when bidirectional) for the raster and the cycloid, the frame
    // for the spiral and Lissajous. The lead-in and lead-out are outside it.
    constexpr uint32_t repetitive_period_ticks() const {
        switch (cfg_.pattern) {
            case ScanPattern::kSpiral:
            case ScanPattern::kLissajous: return frame_period_ticks();
            default: return (cfg_.bidirectional || cfg_.pattern == ScanPattern::kCycloid ? 2u : 1u) * sweep_.line_ticks();
        }
    }
    // A Lissajous axis's own period (0: x, 1: y) when its sinusoid repeats
    // after a whole number of ticks (f / f_s = 1 / n), else the frame: each
    // axis's repetitive controller can learn over its own sinusoid.
    constexpr uint32_t lissajous_axis_period_ticks(int axis) const {
        const trajectory_detail::PhaseStep& s = axis == 0 ? lissajous_params_.step_x : lissajous_params_.step_y;
        const uint64_t num = (uint64_t{s.inc} * s.den + s.rem) >> 32;
        return num == 1 ? s.den : lissajous_params_.frame_ticks;
    }
    constexpr uint32_t lines_per_frame() const {
        switch (cfg_.pattern) {
            case ScanPattern::kSpiral: return cfg_.turns;
            case ScanPattern::kLissajous: return lissajous_.lines();
            default: return cfg_.lines_per_frame;
        }
    }
    // Ticks of the lead-in before the first frame (raster, cycloid), else 0.
    constexpr uint32_t lead_in_ticks() const {
        if (cfg_.pattern != ScanPattern::kRaster && cfg_.pattern != ScanPattern::kCycloid) return 0;
        return sweep_params_.sine ? 0u : sweep_params_.turn_ticks;
    }
    constexpr double reach_um() const { return reach_um_; }
    // The path's derived numbers (ticks, Q47 / Q31 of the reach).
    constexpr const LineSweepParams& sweep_params() const { return sweep_params_; }
    constexpr const SpiralParams& spiral_params() const { return spiral_params_; }
    constexpr const LissajousParams& lissajous_params() const { return lissajous_params_; }
    constexpr uint32_t circle_ticks() const { return circle_ticks_; }
    // CLV spiral: the tangential speed actually produced (the centre region's
    // end rounded to a tick), µm/s.
    constexpr double clv_speed_um_s() const { return clv_speed_um_s_; }
    constexpr const ScanConfig& config() const { return cfg_; }

private:
    // What configure() derives, committed only when everything is valid.
    struct Derived {
        LineSweepParams sweep{};
        SpiralParams spiral{};
        LissajousParams lissajous{};
        double reach_um = 0.0;
        double circle_um = 0.0;
        uint32_t circle_ticks = 0;
        double clv_speed_um_s = 0.0;
    };

    static constexpr Status sweep_fields(const ScanConfig& c, double fs, Derived& d) {
        using namespace scan_detail;
        if (!in_range(c.size_x_um, 0.0, kMaxUm) || !(c.size_x_um > 0.0f))
            return error("size_x_um", "must be in (0, 1e6] um");
        if (!in_range(c.size_y_um, 0.0, kMaxUm) || !(c.size_y_um > 0.0f))
            return error("size_y_um", "must be in (0, 1e6] um");
        if (c.lines_per_frame < 1 || c.lines_per_frame > 65536)
            return error("lines_per_frame", "must be in [1, 65536]");
        const double width = c.size_x_um, height = c.size_y_um;
        LineSweepParams& p = d.sweep;
        double cv = 0.0, turn = 0.0, retrace = 0.0, ex_line = 0.0, circle = 0.0;
        if (c.pattern == ScanPattern::kRaster && c.fast_axis == FastAxis::kSine) return sine_fields(c, fs, d);
        if (c.pattern == ScanPattern::kRaster) {
            if (!in_range(c.line_rate_Hz, 0.0, fs / 4.0) || !(c.line_rate_Hz > 0.0f) ||
                !(static_cast<double>(c.line_rate_Hz) < fs / 4.0))
                return error("line_rate_Hz", "must be in (0, sample_rate_Hz / 4)");
            if (!in_range(c.retrace_speed_factor, 1.0, 16.0))
                return error("retrace_speed_factor", "must be in [1, 16]");
            if (!in_range(c.overscan_fraction, 0.0, 1.0))
                return error("overscan_fraction", "must be in [0, 1]");
            if (!in_range(c.turnaround_s, 0.0, 1.0e3) || round_half_up(static_cast<double>(c.turnaround_s) * fs) < 2.0)
                return error("turnaround_s", "must be at least 2 ticks (2 / sample_rate_Hz)");
            turn = round_half_up(static_cast<double>(c.turnaround_s) * fs);
            const double k = c.retrace_speed_factor, o = c.overscan_fraction;
            const double line = fs / static_cast<double>(c.line_rate_Hz);
            // line = cv + turn (bidirectional), or cv + retrace + 2 turn with the
            // retrace closing the line at k times the trace speed:
            // v_t (cv + turn) = k v_t (retrace + turn).
            const double budget = c.bidirectional ? line - turn : line / (1.0 + 1.0 / k) - turn;
            if (!(budget >= 1.0))
                return error("turnaround_s", "the turnarounds must be shorter than the line period");
            const double per_pixel = round_half_up(budget / (1.0 + 2.0 * o) / c.pixels_per_line);
            if (per_pixel < 1.0)
                return error("pixels_per_line", "must be at most the ticks of the line's used part (lower line_rate_Hz)");
            const double used = per_pixel * c.pixels_per_line;
            const double over = round_half_up(o * used);
            cv = used + 2.0 * over;
            retrace = c.bidirectional ? 0.0 : round_half_up((cv + turn) / k - turn);
            if (!c.bidirectional && retrace < 1.0)
                return error("retrace_speed_factor", "the retrace at this speed is shorter than a tick: lower it or shorten turnaround_s");
            p.used_ticks = static_cast<uint32_t>(used);
            p.overscan_ticks = static_cast<uint32_t>(over);
            p.bidirectional = c.bidirectional;
            p.slow = c.slow_axis;
        } else {  // cycloid: a bidirectional staircase sweep, a turnaround of one circle turn
            if (!in_range(c.radius_um, 0.0, kMaxUm) || !(c.radius_um > 0.0f))
                return error("radius_um", "must be in (0, 1e6] um");
            if (!in_range(c.turn_rate_Hz, 0.0, fs / 4.0) || !(c.turn_rate_Hz > 0.0f) ||
                !(static_cast<double>(c.turn_rate_Hz) < fs / 4.0))
                return error("turn_rate_Hz", "must be in (0, sample_rate_Hz / 4)");
            if (c.turns_per_line < 1 || c.turns_per_line > 65536)
                return error("turns_per_line", "must be in [1, 65536]");
            turn = round_half_up(fs / static_cast<double>(c.turn_rate_Hz));
            cv = turn * c.turns_per_line;
            if (cv > kMaxTicks) return error("turns_per_line", "a line must be shorter than 2^31 ticks");
            if (c.pixels_per_line > cv)
                return error("pixels_per_line", "must be at most the line's ticks (turns_per_line * sample_rate_Hz / turn_rate_Hz)");
            p.used_ticks = static_cast<uint32_t>(cv);
            p.overscan_ticks = 0;
            p.bidirectional = true;
            p.slow = SlowAxis::kStaircase;
            circle = c.radius_um;
            d.circle_ticks = static_cast<uint32_t>(turn);
        }
        const double line_ticks = c.bidirectional || c.pattern == ScanPattern::kCycloid ? cv + turn : cv + retrace + 2.0 * turn;
        if (line_ticks * c.lines_per_frame > kMaxTicks)
            return error("lines_per_frame", "a frame must be shorter than 2^31 ticks");
        p.cv_ticks = static_cast<uint32_t>(cv);
        p.turn_ticks = static_cast<uint32_t>(turn);
        p.retrace_ticks = static_cast<uint32_t>(retrace);
        p.pixels = c.pixels_per_line;
        p.lines = c.lines_per_frame;
        p.frames = c.frames;

        // Extent along the lines: half the constant-velocity run plus the
        // largest run beyond it (a turnaround, the lead-in's start).
        const double vt = width / static_cast<double>(p.used_ticks);  // um per tick
        if (p.bidirectional || c.pattern == ScanPattern::kCycloid) {
            ex_line = turnaround_excursion(vt, vt, turn);
        } else {
            const double vr = vt * (cv + turn) / (retrace + turn);
            const double a = turnaround_excursion(vt, vr, turn), b = turnaround_excursion(vr, vt, turn);
            ex_line = a > b ? a : b;
        }
        if (0.5 * vt * turn > ex_line) ex_line = 0.5 * vt * turn;
        const double ex = 0.5 * vt * cv + ex_line + circle, ey = 0.5 * height + circle;
        d.reach_um = (ex + ey) * kReachMargin;
        d.circle_um = circle;
        const double q47 = 140737488355328.0 / d.reach_um;  // 2^47 per um
        int64_t v47 = static_cast<int64_t>(round_half_up(vt * q47));
        v47 &= ~int64_t{1};  // even: the sweep's start -v cv / 2 is exact
        if (v47 < 2) return error("size_x_um", "too small for the line's ticks");
        p.v_trace = v47;
        p.height = static_cast<int64_t>(round_half_up(height * q47));
        return ok_status();
    }

    // The raster with a sine fast axis: x = -A cos(pi k / half), A = W/2 (1 + 2 o),
    // used where |x| <= W/2: from k1 = half acos(1 / (1 + 2 o)) / pi (rounded) to half - k1.
    static constexpr Status sine_fields(const ScanConfig& c, double fs, Derived& d) {
        using namespace scan_detail;
        if (!in_range(c.line_rate_Hz, 0.0, fs / 4.0) || !(c.line_rate_Hz > 0.0f) ||
            !(static_cast<double>(c.line_rate_Hz) < fs / 4.0))
            return error("line_rate_Hz", "must be in (0, sample_rate_Hz / 4)");
        if (!in_range(c.overscan_fraction, 0.0, 1.0)) return error("overscan_fraction", "must be in [0, 1]");
        const double line = fs / static_cast<double>(c.line_rate_Hz);
        const double half = round_half_up(c.bidirectional ? line : 0.5 * line);  // >= 2: line > 4
        const double o = c.overscan_fraction;
        const double k1 = round_half_up(half * det_acos(1.0 / (1.0 + 2.0 * o)) / kPi);
        const double used = half - 2.0 * k1;
        if (used < c.pixels_per_line)
            return error("pixels_per_line", "must be at most the ticks of the sweep's used part (lower line_rate_Hz or overscan_fraction)");
        if (c.bidirectional && c.slow_axis == SlowAxis::kStaircase && k1 < 2.0)
            return error("overscan_fraction", "a bidirectional sine raster's staircase steps in the overscan: it must last >= 2 ticks");
        const double line_ticks = c.bidirectional ? half : 2.0 * half;
        if (line_ticks * c.lines_per_frame > kMaxTicks)
            return error("lines_per_frame", "a frame must be shorter than 2^31 ticks");
        LineSweepParams& p = d.sweep;
        p.sine = true;
        p.cv_ticks = static_cast<uint32_t>(half);
        p.overscan_ticks = static_cast<uint32_t>(k1);
        p.used_ticks = static_cast<uint32_t>(used);
        p.turn_ticks = 2;  // no turnarounds: unused
        p.retrace_ticks = 0;
        p.pixels = c.pixels_per_line;
        p.lines = c.lines_per_frame;
        p.frames = c.frames;
        p.bidirectional = c.bidirectional;
        p.slow = c.slow_axis;
        const double amplitude = 0.5 * static_cast<double>(c.size_x_um) * (1.0 + 2.0 * o);
        d.reach_um = (amplitude + 0.5 * static_cast<double>(c.size_y_um)) * kReachMargin;
        const double q47 = 140737488355328.0 / d.reach_um;
        p.amplitude = static_cast<int64_t>(round_half_up(amplitude * q47));
        p.v_trace = 2;  // unused
        p.height = static_cast<int64_t>(round_half_up(static_cast<double>(c.size_y_um) * q47));
        return ok_status();
    }

    static constexpr Status spiral_fields(const ScanConfig& c, double fs, Derived& d) {
        using namespace scan_detail;
        if (!in_range(c.radius_um, 0.0, kMaxUm) || !(c.radius_um > 0.0f))
            return error("radius_um", "must be in (0, 1e6] um");
        if (c.turns < 1 || c.turns > 65536) return error("turns", "must be in [1, 65536]");
        if (!in_range(c.turn_rate_Hz, 0.0, fs / 4.0) || !(c.turn_rate_Hz > 0.0f) ||
            !(static_cast<double>(c.turn_rate_Hz) < fs / 4.0))
            return error("turn_rate_Hz", "must be in (0, sample_rate_Hz / 4)");
        if (static_cast<double>(c.pixels_per_line) * static_cast<double>(c.turn_rate_Hz) > fs / 2.0)
            return error("pixels_per_line", "pixels_per_line * turn_rate_Hz must be <= sample_rate_Hz / 2");
        const double turn = round_half_up(fs / static_cast<double>(c.turn_rate_Hz));
        const double cav_ticks = turn * c.turns;
        if (cav_ticks > kMaxTicks / 4.0) return error("turns", "turns / turn_rate_Hz must be below 2^29 ticks");
        SpiralParams& p = d.spiral;
        p.turn_ticks = static_cast<uint32_t>(turn);
        p.turns = c.turns;
        p.pixels = c.pixels_per_line;
        p.frames = c.frames;
        const double radius = c.radius_um;
        d.reach_um = radius * kReachMargin;
        p.radius = static_cast<int64_t>(round_half_up(radius / d.reach_um * 2147483648.0));
        if (c.spiral_mode == SpiralMode::kConstantAngularVelocity) {
            p.centre_ticks = p.out_ticks = static_cast<uint32_t>(cav_ticks);
            p.centre_q2 = 0;
            return ok_status();
        }
        if (c.spiral_mode != SpiralMode::kConstantLinearVelocity) return error("spiral_mode", "unknown spiral mode");
        const double K = c.turns;
        const double f_turn = fs / turn;  // the rate actually produced
        if (!in_range(c.linear_speed_um_s, 0.0, 1.0e9) || !(c.linear_speed_um_s > 0.0f))
            return error("linear_speed_um_s", "must be > 0 and finite");
        // Centre region: up to the radius where the turn rate gives the speed.
        const double r_c = static_cast<double>(c.linear_speed_um_s) / (2.0 * kPi * f_turn);
        const double n_c = round_half_up(r_c / radius * K * turn);
        if (n_c < 1.0)
            return error("linear_speed_um_s", "too low: the centre region (speed / (2 pi turn_rate_Hz)) is below a tick");
        const double theta_c = n_c / turn;  // turns
        if (!(theta_c < K - 1.0 / turn * 2.0))
            return error("linear_speed_um_s", "must be below 2 pi turn_rate_Hz radius_um (the centre region fills the spiral)");
        const double v = 2.0 * kPi * f_turn * radius * theta_c / K;
        const double clv = round_half_up(fs * kPi * radius * (K * K - theta_c * theta_c) / (K * v));
        if (n_c + clv > kMaxTicks / 4.0)
            return error("linear_speed_um_s", "too low: the spiral must take below 2^29 ticks");
        p.centre_ticks = static_cast<uint32_t>(n_c);
        p.out_ticks = static_cast<uint32_t>(n_c + (clv < 2.0 ? 2.0 : clv));
        const double q = theta_c / K;
        p.centre_q2 = static_cast<uint64_t>(q * q * 1152921504606846976.0 + 0.5);  // Q60
        d.clv_speed_um_s = v;
        return ok_status();
    }

    static constexpr Status lissajous_fields(const ScanConfig& c, double fs, Derived& d) {
        using namespace scan_detail;
        if (!in_range(c.size_x_um, 0.0, kMaxUm) || !(c.size_x_um > 0.0f))
            return error("size_x_um", "must be in (0, 1e6] um");
        if (!in_range(c.size_y_um, 0.0, kMaxUm) || !(c.size_y_um > 0.0f))
            return error("size_y_um", "must be in (0, 1e6] um");
        trajectory_detail::PhaseStep sx, sy;
        if (!in_range(c.frequency_x_Hz, 0.0, fs / 4.0) || !(c.frequency_x_Hz > 0.0f) ||
            !(static_cast<double>(c.frequency_x_Hz) < fs / 4.0) ||
            !sinusoid_phase_step(static_cast<double>(c.frequency_x_Hz) / fs, sx))
            return error("frequency_x_Hz", "must be in (0, sample_rate_Hz / 4)");
        if (!in_range(c.frequency_y_Hz, 0.0, fs / 4.0) || !(c.frequency_y_Hz > 0.0f) ||
            !(static_cast<double>(c.frequency_y_Hz) < fs / 4.0) ||
            !sinusoid_phase_step(static_cast<double>(c.frequency_y_Hz) / fs, sy))
            return error("frequency_y_Hz", "must be in (0, sample_rate_Hz / 4)");
        if (!in_range(c.phase_y_deg, -360.0, 360.0)) return error("phase_y_deg", "must be in [-360, 360]");
        if (4.0 * static_cast<double>(c.pixels_per_line) * static_cast<double>(c.frequency_x_Hz) > fs)
            return error("pixels_per_line", "2 * pixels_per_line * frequency_x_Hz must be <= sample_rate_Hz / 2");
        const uint64_t frame = uint64_t{sx.den} / gcd(sx.den, sy.den) * sy.den;
        if (static_cast<double>(frame) > kMaxTicks)
            return error("frequency_y_Hz", "f_x / f_y must be a ratio of small integers: the frame must be below 2^31 ticks");
        LissajousParams& p = d.lissajous;
        p.step_x = sx;
        p.step_y = sy;
        p.den_x = sx.den;
        p.num_x = static_cast<uint32_t>((uint64_t{sx.inc} * sx.den + sx.rem) >> 32);
        p.frame_ticks = static_cast<uint32_t>(frame);
        p.phase_y = phase_of_deg(c.phase_y_deg);
        p.pixels = c.pixels_per_line;
        p.frames = c.frames;
        const double a = 0.5 * static_cast<double>(c.size_x_um), b = 0.5 * static_cast<double>(c.size_y_um);
        d.reach_um = (a + b) * kReachMargin;
        p.amplitude_x = static_cast<int64_t>(round_half_up(a / d.reach_um * 2147483648.0));
        p.amplitude_y = static_cast<int64_t>(round_half_up(b / d.reach_um * 2147483648.0));
        return ok_status();
    }

    constexpr Status configure_fields(const ScanConfig& c) {
        using namespace scan_detail;
        if (!in_range(c.sample_rate_Hz, 0.0, 1.0e9) || !(c.sample_rate_Hz > 0.0f))
            return error("sample_rate_Hz", "must be in (0, 1e9] Hz");
        if (!in_range(c.centre_x_um, -kMaxUm, kMaxUm)) return error("centre_x_um", "must be finite and within +-1e6 um");
        if (!in_range(c.centre_y_um, -kMaxUm, kMaxUm)) return error("centre_y_um", "must be finite and within +-1e6 um");
        if (!in_range(c.hold_z_um, -kMaxUm, kMaxUm)) return error("hold_z_um", "must be finite and within +-1e6 um");
        if (!in_range(c.rotation_deg, -360.0, 360.0)) return error("rotation_deg", "must be in [-360, 360]");
        if (c.pixels_per_line < 1 || c.pixels_per_line > 65536)
            return error("pixels_per_line", "must be in [1, 65536]");
        const double fs = c.sample_rate_Hz;
        Derived d;
        Status s = ok_status();
        switch (c.pattern) {
            case ScanPattern::kRaster:
                if (c.slow_axis != SlowAxis::kStaircase && c.slow_axis != SlowAxis::kRamp)
                    return error("slow_axis", "unknown slow axis");
                if (c.fast_axis != FastAxis::kTriangle && c.fast_axis != FastAxis::kSine)
                    return error("fast_axis", "unknown fast axis");
                s = sweep_fields(c, fs, d);
                break;
            case ScanPattern::kCycloid: s = sweep_fields(c, fs, d); break;
            case ScanPattern::kSpiral: s = spiral_fields(c, fs, d); break;
            case ScanPattern::kLissajous: s = lissajous_fields(c, fs, d); break;
            default: return error("pattern", "unknown pattern");
        }
        if (!s.ok()) return s;

        T cx{}, cy{}, hz{};
        Q31 reach_x{}, reach_y{};
        if constexpr (kFloat) {
            cx = c.centre_x_um;
            cy = c.centre_y_um;
            hz = c.hold_z_um;
        } else {
            const auto fits = [&](SignalScale sc, double centre, double reach) {
                const double f = sc.full_scale;
                return is_finite(sc.full_scale) && f > 0.0 && (centre < 0.0 ? -centre : centre) + reach <= f;
            };
            if (!fits(scale_x_, c.centre_x_um, d.reach_um))
                return error("centre_x_um", "|centre_x_um| + the scan's reach must be <= the x axis' Q31 full scale");
            if (!fits(scale_y_, c.centre_y_um, d.reach_um))
                return error("centre_y_um", "|centre_y_um| + the scan's reach must be <= the y axis' Q31 full scale");
            if (!fits(scale_z_, c.hold_z_um, 0.0))
                return error("hold_z_um", "must be within the z axis' Q31 full scale");
            cx = Q31::from_double(static_cast<double>(c.centre_x_um) / scale_x_.full_scale);
            cy = Q31::from_double(static_cast<double>(c.centre_y_um) / scale_y_.full_scale);
            hz = Q31::from_double(static_cast<double>(c.hold_z_um) / scale_z_.full_scale);
            reach_x = Q31::from_double(d.reach_um / scale_x_.full_scale);
            reach_y = Q31::from_double(d.reach_um / scale_y_.full_scale);
        }

        // Commit.
        cfg_ = c;
        sweep_params_ = d.sweep;
        spiral_params_ = d.spiral;
        lissajous_params_ = d.lissajous;
        reach_um_ = d.reach_um;
        clv_speed_um_s_ = d.clv_speed_um_s;
        if (c.pattern == ScanPattern::kRaster || c.pattern == ScanPattern::kCycloid) sweep_.configure(d.sweep);
        if (c.pattern == ScanPattern::kSpiral) spiral_.configure(d.spiral);
        if (c.pattern == ScanPattern::kLissajous) lissajous_.configure(d.lissajous);
        circle_ticks_ = d.circle_ticks;
        if (circle_ticks_ >= 2) circle_ramp_ = trajectory_detail::make_ramp(circle_ticks_);
        circle_radius_ = static_cast<int64_t>(scan_detail::round_half_up(d.circle_um / d.reach_um * 2147483648.0));
        const uint32_t rot = scan_detail::phase_of_deg(c.rotation_deg);
        cos_ = rot == 0 ? int64_t{1} << 31 : sine_q31(rot + 0x40000000u);
        sin_ = rot == 0 ? 0 : sine_q31(rot);
        centre_x_ = cx;
        centre_y_ = cy;
        hold_z_ = hz;
        reach_f_ = static_cast<float>(d.reach_um);
        reach_x_q_ = reach_x;
        reach_y_q_ = reach_y;
        configured_ = true;
        restart();
        return ok_status();
    }

    SignalScale scale_x_{}, scale_y_{}, scale_z_{};
    ScanConfig cfg_{};
    bool configured_ = false;
    LineSweepParams sweep_params_{};
    SpiralParams spiral_params_{};
    LissajousParams lissajous_params_{};
    LineSweep sweep_{};
    SpiralPath spiral_{};
    LissajousPath lissajous_{};
    double reach_um_ = 0.0, clv_speed_um_s_ = 0.0;
    int64_t cos_ = int64_t{1} << 31, sin_ = 0;  // Q31 (cos 0 = 2^31 exactly)
    T centre_x_{}, centre_y_{}, hold_z_{};
    float reach_f_ = 0.0f;
    Q31 reach_x_q_{}, reach_y_q_{};
    // The cycloid's circle: Q31 of the reach, a turn every circle_ticks_.
    int64_t circle_radius_ = 0;
    uint32_t circle_ticks_ = 0, circle_k_ = 0;
    trajectory_detail::Ramp circle_ramp_{};
};

}  // namespace piezoloop
