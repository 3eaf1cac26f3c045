// The Lissajous path: x = A sin(2 pi f_x t), y = B sin(2 pi f_y t + phi)
// (Tuma et al., Nanotechnology 23, 185501, 2012).
//
// Each frequency is the exact rational f / f_s = num / den of the
// trajectory generator (trajectory.hpp), and the phase of tick n is
// (n num mod den) / den of a cycle, so the path repeats exactly after
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
    uint32_t num_x = 1, den_x = 3, num_y = 1, den_y = 3;  // f / f_s = num / den, den >= 3
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
        ramp_x_ = trajectory_detail::make_ramp(p.den_x);
        ramp_y_ = trajectory_detail::make_ramp(p.den_y);
        restart();
    }
    constexpr void restart() {
        n_ = 0;
        mx_ = 0;
        my_ = 0;
        frame_ = 0;
        done_ = false;
        // The count on the tick before the first (the frame's last), so the
        // first frame's events are every frame's.
        last_pixel_ = pixel_of(trajectory_detail::apply_ramp(ramp_x_, p_.den_x - p_.num_x));
    }

    constexpr uint32_t step(int64_t& x, int64_t& y) {
        const uint32_t px = trajectory_detail::apply_ramp(ramp_x_, mx_);
        const uint32_t py = trajectory_detail::apply_ramp(ramp_y_, my_) + p_.phase_y;
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
        mx_ += p_.num_x;
        if (mx_ >= p_.den_x) mx_ -= p_.den_x;
        my_ += p_.num_y;
        if (my_ >= p_.den_y) my_ -= p_.den_y;
        if (++n_ == p_.frame_ticks) {
            n_ = 0;
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

    LissajousParams p_{};
    trajectory_detail::Ramp ramp_x_{}, ramp_y_{};
    uint32_t n_ = 0, mx_ = 0, my_ = 0, frame_ = 0;
    uint32_t last_pixel_ = 0;
    bool done_ = false;
};

}  // namespace piezoloop
