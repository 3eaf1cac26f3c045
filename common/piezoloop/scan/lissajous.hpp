// The Lissajous path: x = A sin(2 pi f_x t), y = B sin(2 pi f_y t + phi)
// (Tuma et al., Nanotechnology 23, 2012).
//
// Each frequency is the exact rational f / f_s = num / den of the
// trajectory generator (trajectory.hpp), and the phase of tick n is
// (n num mod den) / den of a cycle, carried exactly (an integer part and a
// Bresenham remainder) and rounded up to 2^-32 cycle, so the path repeats exactly after
// lcm(den_x, den_y) ticks: the frame, 1 / gcd(f_x, f_y) in time. Units: Q31
// of the reach (2^31 = the reach >= A + B). The sine from sine_table.hpp.
//
// Events: frame start at n = 0. A line is a half period of x, from one x
// extreme to the other (2 f_x / gcd(f_x, f_y) lines a frame), with P pixels
// evenly in time: the count floor((phase_x + 1/4) 2P) (phases in cycles,
// mod 1; 0 at x = -A) is taken every tick, a pixel clock marks the tick on
// which it changes, a line start the tick on which it becomes a multiple
// of P (x at -A or +A).
#pragma once

#include <cstdint>

#include "piezoloop/scan/scan_config.hpp"
#include "piezoloop/sine_table.hpp"
#include "piezoloop/trajectory.hpp"

namespace piezoloop {

struct LissajousParams {
    trajectory_detail::PhaseStep step_x{}, step_y{};       // f / f_s as phase LSBs a tick
    uint32_t num_x = 1, den_x = 3;                         // f_x / f_s = num / den
    uint32_t frame_ticks = 3;                              // lcm(den_x, den_y)
    int64_t amplitude_x = 0, amplitude_y = 0;              // Q31 of the reach
    uint32_t phase_y = 0;                                  // 2^32 = a cycle
    uint32_t pixels = 1;
    uint32_t frames = 1;                                   // 0 = forever
};

class LissajousPath {
public:
    constexpr void configure(const LissajousParams& p) {
        p_ = p;
        restart();
    }
    constexpr void restart() {
        n_ = 0;
        x_ = {};
        y_ = {};
        frame_ = 0;
        done_ = false;
        // The count on the tick before the first (the frame's last), so the
        // first frame's events are every frame's: phase -num/den, rounded up.
        const uint64_t before = (uint64_t{p_.den_x - p_.num_x} << 32) / p_.den_x;
        const bool exact = ((uint64_t{p_.den_x - p_.num_x} << 32) % p_.den_x) == 0;
        last_pixel_ = pixel_of(static_cast<uint32_t>(before + (exact ? 0u : 1u)));
    }

    constexpr uint32_t step(int64_t& x, int64_t& y) {
        const uint32_t px = x_.phase();
        const uint32_t py = y_.phase() + p_.phase_y;
        x = (p_.amplitude_x * sine_q31(px)) >> 31;
        y = (p_.amplitude_y * sine_q31(py)) >> 31;
        if (done_) return 0;
        uint32_t sync = n_ == 0 ? kSyncFrameStart : 0u;
        const uint32_t pixel = pixel_of(px);
        if (pixel != last_pixel_) {
            sync |= kSyncPixel;
            if (pixel % p_.pixels == 0) sync |= kSyncLineStart;
            last_pixel_ = pixel;
        }
        x_.advance(p_.step_x);
        y_.advance(p_.step_y);
        if (++n_ == p_.frame_ticks) {
            n_ = 0;
            x_ = {};  // exactly where it was: the frame is a whole number of both periods
            y_ = {};
            ++frame_;
            // Held at the frame's start (the next tick's position).
            if (p_.frames != 0 && frame_ >= p_.frames) done_ = true;
        }
        return sync;
    }

    constexpr bool done() const { return done_; }
    constexpr uint32_t frame_ticks() const { return p_.frame_ticks; }
    constexpr uint32_t frames_completed() const { return frame_; }
    // x half periods a frame.
    constexpr uint32_t lines() const {
        return static_cast<uint32_t>(2 * (uint64_t{p_.num_x} * p_.frame_ticks / p_.den_x));
    }

private:
    // Pixels since the last x minimum, [0, 2P): phase 3/4 (x = -A) counts 0.
    constexpr uint32_t pixel_of(uint32_t px) const {
        return static_cast<uint32_t>((uint64_t{px + 0x40000000u} * (2 * uint64_t{p_.pixels})) >> 32);
    }

    // Phase n f / f_s: acc + err / den LSBs; phase() rounds it up.
    struct Phase {
        uint32_t acc = 0, err = 0;
        constexpr uint32_t phase() const { return acc + (err != 0 ? 1u : 0u); }
        constexpr void advance(const trajectory_detail::PhaseStep& s) {
            acc += s.inc;
            err += s.rem;
            if (err >= s.den) { err -= s.den; ++acc; }
        }
    };

    LissajousParams p_{};
    Phase x_{}, y_{};
    uint32_t n_ = 0, frame_ = 0;
    uint32_t last_pixel_ = 0;
    bool done_ = false;
};

}  // namespace piezoloop
