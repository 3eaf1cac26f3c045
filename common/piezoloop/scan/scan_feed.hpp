// The scan feed: runs a scan on a MultiAxisPipeline's axes, one tick at a
// time, in the tick's reading-independent half (before begin_tick()).
//
//   start(config, from_x, from_y[, from_z]): validates the scan (errors as
//       ScanGenerator::configure names them, group "scan"; the loop rate
//       must be the feed's) and plans a minimum-jerk approach (approach.hpp)
//       of each axis from where the stage is (the axes' held setpoints or
//       their readings) to the scan's start_point(); z approaches the held
//       height. Each axis moves at most its approach bound per tick.
//   step(): this tick's setpoints and sync word: approach samples
//       n = 1 .. A (A = approach_ticks(): the longest axis's N - 1; an axis
//       whose own approach ends sooner holds its target), then the scan's
//       clock, whose first tick is start_point() exactly. The sync word is
//       zero during the approach, so the scan's events come A ticks later
//       than the generator's alone.
//   feed(pipeline): step() and each axis's set_setpoint (x -> axis 0,
//       y -> axis 1, z -> axis 2 when the pipeline has three axes).
//   stop(): the setpoints hold where they are; done() after the last frame
//       (or a stop).
//
// Freestanding, float and Q31 (positions in each axis's Q31 scale): the
// path is the generator's and the approach's, bit for bit.
#pragma once

#include <array>
#include <cstdint>
#include <type_traits>
#include <utility>  // std::tuple_size_v

#include "piezoloop/approach.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/scan/scan_config.hpp"
#include "piezoloop/scan/scan_generator.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

template <class T>
class ScanFeed {
    static_assert(is_sample_type_v<T>, "ScanFeed<T>: T is float or Q31");

public:
    // The axes' position scales (µm <-> Q31; float ignores them) and the
    // loop rate (> 0).
    constexpr ScanFeed(SignalScale x, SignalScale y, SignalScale z, float rate_Hz)
        : generator_(x, y, z), approach_{Approach<T>(x, rate_Hz), Approach<T>(y, rate_Hz), Approach<T>(z, rate_Hz)},
          rate_Hz_(rate_Hz) {}

    // On error nothing changes (a running scan goes on).
    constexpr Status start(const ScanConfig& c, T from_x, T from_y, T from_z = T{}) {
        if (!(c.sample_rate_Hz == rate_Hz_))
            return in_group("scan", error("sample_rate_Hz", "must equal the loop rate"));
        if constexpr (std::is_same_v<T, float>) {
            if (!is_finite(from_x) || !is_finite(from_y) || !is_finite(from_z))
                return in_group("scan", error("from", "the start position must be finite"));
        }
        ScanGenerator<T> g = generator_;
        if (const Status s = g.configure(c); !s.ok()) return s;
        generator_ = g;
        const ScanPoint<T> first = generator_.start_point();
        const std::array<T, 3> from{from_x, from_y, from_z};
        const std::array<T, 3> to{first.x, first.y, first.z};
        approach_ticks_ = 0;
        for (int i = 0; i < 3; ++i) {
            held_[i] = from[i];
            target_[i] = to[i];
            moving_[i] = approach_[i].begin(from[i], to[i]);
            if (moving_[i] && approach_[i].ticks() - 1 > approach_ticks_) approach_ticks_ = approach_[i].ticks() - 1;
        }
        tick_ = 0;
        state_ = State::kRunning;
        return ok_status();
    }

    // This tick's setpoints and events (see the top of the file).
    constexpr ScanPoint<T> step() {
        ScanPoint<T> p;
        if (state_ == State::kRunning && tick_ < approach_ticks_) {
            for (int i = 0; i < 3; ++i) {
                if (moving_[i]) {
                    held_[i] = approach_[i].step();
                    moving_[i] = approach_[i].moving();
                } else {
                    held_[i] = target_[i];
                }
            }
            ++tick_;
        } else if (state_ == State::kRunning) {
            const ScanPoint<T> s = generator_.step();
            held_ = {s.x, s.y, s.z};
            p.sync = s.sync;
            ++tick_;
            if (generator_.done()) state_ = State::kDone;
        }
        p.x = held_[0];
        p.y = held_[1];
        p.z = held_[2];
        return p;
    }

    // step() into the pipeline's setpoints; returns the tick's point.
    template <class Pipeline>
    ScanPoint<T> feed(Pipeline& pipeline) {
        const ScanPoint<T> p = step();
        pipeline.axis(0).set_setpoint(p.x);
        pipeline.axis(1).set_setpoint(p.y);
        if constexpr (std::tuple_size_v<typename Pipeline::Samples> > 2) pipeline.axis(2).set_setpoint(p.z);
        return p;
    }

    constexpr void stop() {
        if (state_ == State::kRunning) state_ = State::kDone;
    }

    constexpr bool running() const { return state_ == State::kRunning; }
    constexpr bool approaching() const { return state_ == State::kRunning && tick_ < approach_ticks_; }
    constexpr bool done() const { return state_ == State::kDone; }
    // Ticks of the approach before the scan's clock starts (0: none).
    constexpr uint32_t approach_ticks() const { return approach_ticks_; }
    // Ticks stepped since start (approach included).
    constexpr uint64_t ticks() const { return tick_; }
    constexpr const ScanGenerator<T>& generator() const { return generator_; }
    // The largest approach step per tick of axis i (sample units; Q31: raw LSB).
    constexpr float approach_unit(int i) const { return approach_[i].unit(); }

private:
    enum class State : uint8_t { kIdle, kRunning, kDone };
    ScanGenerator<T> generator_;
    std::array<Approach<T>, 3> approach_;
    float rate_Hz_;
    std::array<T, 3> held_{}, target_{};
    std::array<bool, 3> moving_{};
    uint32_t approach_ticks_ = 0;
    uint64_t tick_ = 0;
    State state_ = State::kIdle;
};

}  // namespace piezoloop
