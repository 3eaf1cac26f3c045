// The spiral's path: an Archimedean spiral r = R theta / (2 pi K) from the
// centre out to the radius R in K whole turns, then back in.
//
//   CAV: theta = 2 pi n / N_turn, r = R n / (K N_turn)   (fixed angular rate)
//   CLV: as CAV for n < n_c (the centre region, at the turn rate), then
//        theta^2 = theta_c^2 + 2 v (t - t_c) / a,  a = R / (2 pi K),
//        so r theta' = v (the tangential speed) is constant; the angular rate
//        is continuous at n_c (v = 2 pi f_turn r_c). The speed, with the radial
//        part, is v sqrt(1 + 1/theta^2): within 1/(2 theta^2) of v.
//   In the CLV part q = r / R = sqrt(q_c^2 + (1 - q_c^2) (n - n_c) / (N_out - n_c))
//   (fixed_sqrt.hpp) and theta = 2 pi K q.
//
// Return: the mirror image in x of the outward path run backwards,
// (x, y)(N_out + m) = (x, -y)(N_out - m): the angle keeps turning the same
// way, so the tangential velocity is continuous at the outer radius and only
// the (small, pitch-sized) radial velocity reverses; the frame ends at the
// centre where the next begins. Frame: 2 N_out ticks.
//
// Units: Q31 of the reach (2^31 = the reach >= R). Integer arithmetic only.
//
// Events (outward half only): frame start at n = 0; a line is a turn, line
// start on the first tick of each turn; a pixel clock on the first tick at
// or after each j/P of a turn in angle: at constant angular rate exactly the
// ticks ceil(j N_turn / P) of the turn (evenly in time), in the CLV part from
// the computed angle.
#pragma once

#include <cstdint>

#include "piezoloop/scan/fixed_sqrt.hpp"
#include "piezoloop/scan/scan_config.hpp"
#include "piezoloop/sine_table.hpp"
#include "piezoloop/trajectory.hpp"

namespace piezoloop {

struct SpiralParams {
    uint32_t turn_ticks = 2;     // N_turn: ticks per turn at the turn rate
    uint32_t turns = 1;          // K
    uint32_t centre_ticks = 0;   // n_c (CAV: K N_turn = out_ticks)
    uint32_t out_ticks = 2;      // N_out
    uint64_t centre_q2 = 0;      // q_c^2, Q60
    int64_t radius = 0;          // R, Q31 of the reach
    uint32_t pixels = 1;
    uint32_t frames = 1;         // 0 = forever
};

class SpiralPath {
public:
    constexpr void configure(const SpiralParams& p) {
        p_ = p;
        turn_ramp_ = trajectory_detail::make_ramp(p.turn_ticks);
        radius_ramp_ = trajectory_detail::make_ramp(uint64_t{p.turns} * p.turn_ticks);
        clv_ramp_ = p.out_ticks - p.centre_ticks >= 2 ? trajectory_detail::make_ramp(p.out_ticks - p.centre_ticks)
                                                      : trajectory_detail::Ramp{};
        restart();
    }
    constexpr void restart() {
        n_ = 0;
        frame_ = 0;
        done_ = false;
        last_pixel_ = 0;
        last_turn_ = 0;
        phase_tick_ = 0;
        pixel_acc_ = 0;
        pixel_in_turn_ = 0;
    }

    // This tick's position (Q31 of the reach) and events; advances one tick.
    constexpr uint32_t step(int64_t& x, int64_t& y) {
        if (done_) { x = 0; y = 0; return 0; }
        uint32_t sync = 0;
        if (n_ < p_.out_ticks) {
            uint32_t turn = 0, phase = 0;
            outward(n_, x, y, turn, phase);
            if (n_ < p_.centre_ticks) {
                // Constant rate: turn starts at k = 0, pixels on the ticks
                // ceil(j N_turn / P) of a turn (pixel_acc_ = k P mod N_turn).
                if (phase_tick_ == 0) {
                    sync |= kSyncLineStart;
                    pixel_acc_ = 0;
                    pixel_in_turn_ = 0;
                    if (n_ == 0) sync |= kSyncFrameStart;
                }
                if (pixel_acc_ < p_.pixels) {
                    sync |= kSyncPixel;
                    last_pixel_ = uint64_t{turn} * p_.pixels + pixel_in_turn_++;
                }
                last_turn_ = turn;
                pixel_acc_ += p_.pixels;
                if (pixel_acc_ >= p_.turn_ticks) pixel_acc_ -= p_.turn_ticks;
                if (++phase_tick_ == p_.turn_ticks) phase_tick_ = 0;
            } else {
                // CLV: from the angle. Only forward steps count (the root's
                // rounding cannot make one fire twice).
                const uint64_t pixel = uint64_t{turn} * p_.pixels + ((uint64_t{phase} * p_.pixels) >> 32);
                if (pixel > last_pixel_) { sync |= kSyncPixel; last_pixel_ = pixel; }
                if (turn > last_turn_) { sync |= kSyncLineStart; last_turn_ = turn; }
            }
        } else {
            uint32_t turn = 0, phase = 0;
            outward(2 * p_.out_ticks - n_, x, y, turn, phase);
            y = -y;
        }
        if (++n_ == 2 * p_.out_ticks) {
            n_ = 0;
            phase_tick_ = 0;
            ++frame_;
            if (p_.frames != 0 && frame_ >= p_.frames) done_ = true;
        }
        return sync;
    }

    constexpr bool done() const { return done_; }
    constexpr uint32_t frame_ticks() const { return 2 * p_.out_ticks; }
    constexpr uint32_t frames_completed() const { return frame_; }

    // The outward path at tick n in [0, N_out]: position, whole turns, and
    // the angle within the turn (2^32 = a turn).
    constexpr void outward(uint32_t n, int64_t& x, int64_t& y, uint32_t& turn, uint32_t& phase) const {
        int64_t r = 0;
        if (n >= p_.out_ticks) {
            r = p_.radius;
            turn = p_.turns;
            phase = 0;
        } else if (n < p_.centre_ticks) {
            turn = n / p_.turn_ticks;
            phase = trajectory_detail::apply_ramp(turn_ramp_, n - turn * p_.turn_ticks);
            r = (p_.radius * trajectory_detail::apply_ramp(radius_ramp_, n)) >> 32;
        } else {
            const uint64_t frac = trajectory_detail::apply_ramp(clv_ramp_, n - p_.centre_ticks);
            const uint64_t span = (uint64_t{1} << 60) - p_.centre_q2;
            const uint64_t q2 = p_.centre_q2 + (((span >> 28) * frac) >> 4);  // Q60, <= 1
            const uint64_t q = fixed_sqrt(q2);                                 // Q30
            const uint64_t angle = uint64_t{p_.turns} * q;                     // turns, Q30
            turn = static_cast<uint32_t>(angle >> 30);
            phase = static_cast<uint32_t>(angle << 2);
            r = (p_.radius * static_cast<int64_t>(q)) >> 30;
        }
        x = (r * sine_q31(phase + 0x40000000u)) >> 31;
        y = (r * sine_q31(phase)) >> 31;
    }

private:
    SpiralParams p_{};
    trajectory_detail::Ramp turn_ramp_{}, radius_ramp_{}, clv_ramp_{};
    uint32_t n_ = 0, frame_ = 0;
    bool done_ = false;
    uint64_t last_pixel_ = 0;
    uint32_t last_turn_ = 0;
    uint32_t phase_tick_ = 0, pixel_acc_ = 0, pixel_in_turn_ = 0;  // centre region: tick in the turn, k P mod N_turn, pixels so far
};

}  // namespace piezoloop
