// The raster's path: a fast axis swept along lines at constant velocity,
// with turnarounds of bounded jerk, and a slow axis stepping (or ramping)
// between lines. The cycloid runs its circle's centre along the same path.
//
// Units: positions in Q47 of the scan's reach (2^47 = the reach, the radius
// about the centre that holds the whole path, see scan_generator.hpp),
// velocities in Q47 per tick. All integer arithmetic, so float and Q31
// share the path bit for bit on every target.
//
// One line (ticks, from its first):
//   unidirectional: trace at +v_t (cv ticks), turnaround A (turn ticks,
//     +v_t -> -v_r), retrace at -v_r (retrace ticks), turnaround B
//     (-v_r -> +v_t; a staircase steps here)
//   bidirectional:  sweep at v_t (cv ticks), turnaround (v_t -> -v_t;
//     a staircase steps here); every other line is the mirror image.
// The sweep's constant-velocity part is overscan + used + overscan ticks;
// pixels lie in the used part.
//
// Turnaround from v_in to v_out over T ticks, x = tau / T in [0, 1]:
//   v = v_in + (v_out - v_in) s(x),       s(x) = 3x^2 - 2x^3
//   p = p0 + v_in tau + (v_out - v_in) T S(x),   S(x) = x^3 - x^4 / 2
// s has zero slope at both ends, so the acceleration is continuous (zero
// where the constant velocity meets it) and the jerk
// (v_out - v_in) s''(x) / T^2 is bounded by 6 |v_out - v_in| / T^2.
// Displacement over a turnaround: (v_in + v_out) T / 2.
// The retrace closes each line, v_t (cv + turn) = v_r (retrace + turn): the
// generator takes retrace = round((cv + turn) / k - turn) ticks for a speed
// factor k and v_r follows (k within the rounding of a tick).
//
// Slow axis: a staircase holds y_i = -H/2 + i H / (L - 1) over line i and
// moves to the next line's y during turnaround B (bidirectional: the
// turnaround) along the minimum-jerk profile 10x^3 - 15x^4 + 6x^5
// (approach.hpp); a ramp moves y from -H/2 to +H/2 at constant speed over
// the frame. Frames alternate upward and downward, so a frame ends where
// the next begins (no jump); a ramp reverses its (slow) velocity there.
//
// Start and end: a lead-in accelerates from rest to +v_t over a turnaround's
// ticks before the first line, and, when the frames are counted, a lead-out
// stops the last line's final turnaround at rest instead. Both are
// turnarounds as above.
//
// Sine fast axis (raster): x = -A cos(pi k / sweep) instead, A = W/2 (1 + 2
// overscan); the used part is where |x| <= W/2 (to a tick), pixels evenly in
// time over it; a staircase steps outside it (the retrace half, or the
// overscan after it); no lead-in: the sweep starts at rest.
//
// Events: frame start on the first tick of a frame's first line, line start
// on the first tick of each line's sweep, a pixel clock on the ticks
// ceil(j * used / P), j = 0..P-1, after the overscan (the raster makes used a
// multiple of P: pixels evenly spaced in position).
#pragma once

#include <array>
#include <cstdint>

#include "piezoloop/approach.hpp"
#include "piezoloop/scan/scan_config.hpp"
#include "piezoloop/sine_table.hpp"
#include "piezoloop/trajectory.hpp"

namespace piezoloop {

namespace scan_detail {

// a * q / 2^31 for |a| < 2^55 and q in [0, 2^31], in two 64-bit products
// (a's top and its low 24 bits), within 2 of the exact value.
constexpr int64_t times_q31(int64_t a, int64_t q) {
    const int64_t hi = a >> 24, lo = a & 0xffffff;
    return ((hi * q) >> 7) + ((lo * q) >> 31);
}

// S(x) = x^3 - x^4 / 2 for x = p / 2^32, Q31, in [0, 2^30).
constexpr int64_t blend_q31(uint32_t p) {
    const uint64_t x = p >> 1;
    const uint64_t x2 = (x * x) >> 31;
    const uint64_t x3 = (x2 * x) >> 31;
    const uint64_t x4 = (x3 * x) >> 31;
    return static_cast<int64_t>(x3) - static_cast<int64_t>(x4 >> 1);
}

}  // namespace scan_detail

// What the generator derives from a ScanConfig for the path (ticks and Q47).
struct LineSweepParams {
    uint32_t cv_ticks = 0;        // constant-velocity part of a sweep: overscan + used + overscan
    uint32_t overscan_ticks = 0;
    uint32_t used_ticks = 0;      // >= pixels
    uint32_t turn_ticks = 2;      // each turnaround, lead-in and lead-out, >= 2
    uint32_t retrace_ticks = 0;   // unidirectional, >= 1
    uint32_t pixels = 1;
    uint32_t lines = 1;
    uint32_t frames = 1;          // 0 = forever
    bool bidirectional = false;
    SlowAxis slow = SlowAxis::kStaircase;
    int64_t v_trace = 0;          // Q47 per tick, > 0, even
    int64_t height = 0;           // Q47, the slow axis' span H
    // Sine fast axis: x = -A cos(pi k / cv_ticks) over a sweep of cv_ticks
    // (a half period; unidirectional lines are a full period, the second
    // half the retrace); used_ticks in the middle of the sweep, overscan_ticks
    // before and after; no lead-in or lead-out (it starts and ends at rest).
    bool sine = false;
    int64_t amplitude = 0;        // Q47, A
};

class LineSweep {
    struct Segment {
        uint32_t len = 0;
        trajectory_detail::Ramp ramp{};
        int64_t x0 = 0;       // Q47
        int64_t v = 0;        // Q47 per tick, at the segment's start
        int64_t e = 0;        // turnaround: (v_out - v_in) * len, Q47; 0: constant velocity
        bool step_y = false;  // a staircase steps here
    };

public:
    // p must satisfy the generator's checks (positive ticks, no overflow).
    constexpr void configure(const LineSweepParams& p) {
        p_ = p;
        const int64_t vt = p.v_trace;
        const int64_t x_start = -(vt * p.cv_ticks) / 2;  // exact: v_trace is even
        const auto blend = [&](int64_t x0, int64_t v_in, int64_t v_out, bool step) {
            Segment s;
            s.len = p.turn_ticks;
            s.ramp = trajectory_detail::make_ramp(p.turn_ticks);
            s.x0 = x0;
            s.v = v_in;
            s.e = (v_out - v_in) * p.turn_ticks;
            s.step_y = step;
            return s;
        };
        const auto end_of = [](const Segment& s) {  // where the formula would put tick len: S(1) = 1/2
            return s.x0 + s.v * s.len + s.e / 2;
        };
        Segment trace;
        trace.len = p.cv_ticks;
        trace.x0 = x_start;
        trace.v = vt;
        seg_[0] = trace;
        if (p.bidirectional) {
            seg_[1] = blend(x_start + vt * p.cv_ticks, vt, -vt, true);
            segments_ = 2;
            lead_out_ = blend(seg_[1].x0, vt, 0, false);
        } else {
            const int64_t vr = (vt * (int64_t{p.cv_ticks} + p.turn_ticks) + (p.retrace_ticks + p.turn_ticks) / 2) /
                               (int64_t{p.retrace_ticks} + p.turn_ticks);
            seg_[1] = blend(x_start + vt * p.cv_ticks, vt, -vr, false);
            Segment retrace;
            retrace.len = p.retrace_ticks;
            retrace.x0 = end_of(seg_[1]);
            retrace.v = -vr;
            seg_[2] = retrace;
            seg_[3] = blend(retrace.x0 - vr * p.retrace_ticks, -vr, vt, true);
            segments_ = 4;
            lead_out_ = blend(seg_[3].x0, -vr, 0, false);
            v_retrace_ = vr;
        }
        if (p.sine) {
            // One segment a line; its ramp runs over the full period.
            Segment line;
            line.len = p.bidirectional ? p.cv_ticks : 2 * p.cv_ticks;
            line.ramp = trajectory_detail::make_ramp(2 * uint64_t{p.cv_ticks});
            seg_[0] = line;
            segments_ = 1;
            // The staircase steps outside the used part: over the retrace
            // half, or (bidirectional) over the overscan after the used part.
            step_from_ = p.bidirectional ? p.overscan_ticks + p.used_ticks : p.cv_ticks;
            const uint32_t step_len = p.bidirectional ? p.overscan_ticks : p.cv_ticks;
            step_ramp_ = trajectory_detail::make_ramp(step_len >= 2 ? step_len : 2);
        }
        lead_in_ = blend(0, 0, vt, false);
        lead_in_.x0 = x_start - lead_in_.e / 2;  // ends at the trace's start
        line_ticks_ = 0;
        for (uint32_t i = 0; i < segments_; ++i) line_ticks_ += seg_[i].len;
        frame_ticks_ = line_ticks_ * p.lines;
        frame_ramp_ = trajectory_detail::make_ramp(frame_ticks_);
        y_pitch_ = p.lines > 1 ? p.height / (p.lines - 1) : 0;
        restart();
    }

    constexpr void restart() {
        lead_in_left_ = !p_.sine;
        frame_ = 0;
        line_ = 0;
        seg_index_ = 0;
        k_ = 0;
        frame_tick_ = 0;
        pixel_acc_ = 0;
        mirrored_ = false;
        done_ = false;
        lead_out_now_ = false;
    }

    // This tick's position (Q47 of the reach; x along the lines, y across)
    // and its events; then advances one tick. After the last frame (and its
    // lead-out) the path holds its end point.
    constexpr uint32_t step(int64_t& x, int64_t& y) {
        if (done_) {
            x = hold_x_;
            y = hold_y_;
            return 0;
        }
        uint32_t sync = 0;
        y = slow_position();
        if (lead_in_left_) {
            x = position(lead_in_, k_);
            if (++k_ == lead_in_.len) { k_ = 0; lead_in_left_ = false; }
            return 0;
        }
        const Segment& s = lead_out_now_ ? lead_out_ : seg_[seg_index_];
        if (p_.sine) {
            // -A cos(2 pi k / (2 cv)) = A sin(phase - 1/4 cycle).
            x = scan_detail::times_q31(p_.amplitude, sine_q31(trajectory_detail::apply_ramp(s.ramp, k_) - 0x40000000u));
            if (p_.slow == SlowAxis::kStaircase && k_ >= step_from_)
                y = staircase_step(y, k_ - step_from_, step_ramp_);
        } else {
            x = position(s, k_);
            if (s.step_y && p_.slow == SlowAxis::kStaircase) y = staircase_step(y, k_, s.ramp);
        }
        if (mirrored_) x = -x;
        if (seg_index_ == 0) {
            if (k_ == 0) {
                sync |= kSyncLineStart;
                if (line_ == 0) sync |= kSyncFrameStart;
            }
            if (k_ >= p_.overscan_ticks && k_ - p_.overscan_ticks < p_.used_ticks) {
                // pixel_acc_ = (k - overscan) * P mod used: a pixel starts when it wraps.
                if (pixel_acc_ < p_.pixels) sync |= kSyncPixel;
                pixel_acc_ += p_.pixels;
                if (pixel_acc_ >= p_.used_ticks) pixel_acc_ -= p_.used_ticks;
            }
        }
        advance(x, y);
        return sync;
    }

    constexpr bool done() const { return done_; }
    constexpr uint32_t line_ticks() const { return line_ticks_; }
    constexpr uint32_t frame_ticks() const { return frame_ticks_; }
    constexpr uint32_t frames_completed() const { return frame_; }
    constexpr int64_t retrace_velocity() const { return v_retrace_; }  // Q47 per tick, unidirectional
    constexpr int64_t start_x() const { return lead_in_.x0; }

private:
    static constexpr int64_t position(const Segment& s, uint32_t k) {
        int64_t x = s.x0 + s.v * k;
        if (s.e != 0) x += scan_detail::times_q31(s.e, scan_detail::blend_q31(trajectory_detail::apply_ramp(s.ramp, k)));
        return x;
    }

    // The line index whose y a line holds: frames alternate direction.
    constexpr uint32_t stair_index(uint32_t line) const {
        return (frame_ & 1u) ? p_.lines - 1 - line : line;
    }
    constexpr int64_t stair_y(uint32_t index) const {
        return p_.lines > 1 ? -p_.height / 2 + y_pitch_ * index : 0;  // one line: through the centre
    }

    constexpr int64_t slow_position() const {
        if (p_.slow == SlowAxis::kRamp) {
            if (lead_in_left_) return -p_.height / 2;
            const uint64_t frac = trajectory_detail::apply_ramp(frame_ramp_, frame_tick_);
            // H * t / T, Q47: H / 2^16 <= 2^32 (H <= twice the reach) times frac < 2^32 fits unsigned.
            const int64_t up = static_cast<int64_t>((static_cast<uint64_t>(p_.height >> 16) * frac) >> 16);
            return (frame_ & 1u) ? p_.height / 2 - up : -p_.height / 2 + up;
        }
        if (lead_in_left_) return stair_y(0);
        return stair_y(stair_index(line_));
    }

    // During the step segment, y moves to the next line's (the frame's last
    // line moves nowhere: the next frame starts on the same y).
    constexpr int64_t staircase_step(int64_t y, uint32_t k, trajectory_detail::Ramp ramp) const {
        if (line_ + 1 >= p_.lines) return y;
        const int64_t target = stair_y(stair_index(line_ + 1));
        const int64_t m = approach_detail::min_jerk_q31(trajectory_detail::apply_ramp(ramp, k));
        return y + scan_detail::times_q31(target - y, m);
    }

    constexpr void advance(int64_t x, int64_t y) {
        ++frame_tick_;
        const Segment& s = lead_out_now_ ? lead_out_ : seg_[seg_index_];
        if (++k_ < s.len) return;
        k_ = 0;
        if (lead_out_now_) {  // at rest at the lead-out's end
            const int64_t end = s.x0 + s.v * s.len + s.e / 2;
            hold_x_ = mirrored_ ? -end : end;
            hold_y_ = y;
            ++frame_;
            done_ = true;
            return;
        }
        if (++seg_index_ < segments_) {
            if (seg_index_ + 1 == segments_ && line_ + 1 == p_.lines && p_.frames != 0 && frame_ + 1 == p_.frames)
                lead_out_now_ = true;
            return;
        }
        seg_index_ = 0;
        pixel_acc_ = 0;
        if (p_.bidirectional) mirrored_ = !mirrored_;
        if (++line_ < p_.lines) return;
        line_ = 0;
        frame_tick_ = 0;
        ++frame_;
        if (p_.sine && p_.frames != 0 && frame_ >= p_.frames) {  // at rest at a turning point
            hold_x_ = x;
            hold_y_ = y;
            done_ = true;
        }
    }

    LineSweepParams p_{};
    std::array<Segment, 4> seg_{};
    uint32_t segments_ = 0;
    Segment lead_in_{}, lead_out_{};
    uint32_t line_ticks_ = 0, frame_ticks_ = 0;
    trajectory_detail::Ramp frame_ramp_{};
    int64_t y_pitch_ = 0;
    int64_t v_retrace_ = 0;
    uint32_t step_from_ = 0;                 // sine: the staircase's step starts here in the line
    trajectory_detail::Ramp step_ramp_{};

    // State.
    bool lead_in_left_ = true;
    bool lead_out_now_ = false;
    bool mirrored_ = false;
    bool done_ = false;
    uint32_t frame_ = 0, line_ = 0, seg_index_ = 0, k_ = 0, frame_tick_ = 0;
    uint32_t pixel_acc_ = 0;
    int64_t hold_x_ = 0, hold_y_ = 0;
};

}  // namespace piezoloop
