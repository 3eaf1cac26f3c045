// Mains pickup on a sensor's reading (docs/models.md, 'Sensor offset, gain
// error and mains pickup'): the mains frequency and its harmonics,
//   m(n) = sum_{k=1..K} a_k sin(2 pi k f n / rate),
// in µm of displacement, n the samples since reset. Every harmonic starts
// at phase 0 at reset (a fixed phase; the pickup is periodic and
// deterministic, as a board's would be once synchronised to its mains).
//
// No libm on the per-sample path: one 32-bit phase accumulator (increment
// round(f 2^32 / rate), so the frequency is f within rate / 2^33), harmonic
// k at k times the phase (wrapping modulo 2^32 is the sine's own period), and
// the Q31 sine table (sine_table.hpp, within 2.95e-7 of the sine's
// amplitude).
#pragma once

#include <array>
#include <cstdint>

#include "piezoloop/det_math.hpp"
#include "piezoloop/sine_table.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

inline constexpr int kMaxMainsHarmonics = 8;

struct MainsConfig {
    float frequency_Hz = 50.0f;
    int count = 0;  // harmonics given (0: no pickup)
    std::array<float, kMaxMainsHarmonics> amplitudes_um{};  // fundamental, 2nd, 3rd, ...
    bool operator==(const MainsConfig&) const = default;
};

class MainsPickup {
public:
    // Errors name "frequency_Hz", "count" or "amplitudes_um" (with the
    // harmonic's index).
    Status configure(const MainsConfig& c, float rate_Hz) {
        if (c.count < 0 || c.count > kMaxMainsHarmonics) return error("count", "must be in [0, 8] harmonics");
        for (int i = 0; i < c.count; ++i) {
            const float a = c.amplitudes_um[static_cast<std::size_t>(i)];
            if (!is_finite(a) || !(a >= 0.0f) || a > 1e3f)
                return error("amplitudes_um", i, "must be finite and in [0, 1000] um");
        }
        if (c.count > 0) {
            // The highest harmonic below Nyquist.
            if (!is_finite(c.frequency_Hz) || !(c.frequency_Hz > 0.0f) ||
                !(static_cast<double>(c.frequency_Hz) * c.count < 0.5 * static_cast<double>(rate_Hz)))
                return error("frequency_Hz", "must be > 0 with every harmonic below rate / 2");
        }
        count_ = c.count;
        increment_ = 0u;
        if (c.count > 0) {
            const double inc = static_cast<double>(c.frequency_Hz) / static_cast<double>(rate_Hz) * 4294967296.0 + 0.5;
            increment_ = static_cast<uint32_t>(inc);  // < 2^31: f < rate / 2
        }
        // a_k 2^-31: the Q31 sine times this is the harmonic in µm (a
        // power-of-two scale, exact).
        for (int i = 0; i < kMaxMainsHarmonics; ++i)
            scale_[static_cast<std::size_t>(i)] =
                i < c.count ? c.amplitudes_um[static_cast<std::size_t>(i)] * (1.0f / 2147483648.0f) : 0.0f;
        reset();
        return ok_status();
    }
    bool enabled() const { return count_ > 0; }
    void reset() { phase_ = 0u; }

    // The pickup at this sample, in µm; advances one sample.
    float next_um() {
        float m = 0.0f;
        uint32_t p = phase_;
        for (int i = 0; i < count_; ++i) {
            m = m + scale_[static_cast<std::size_t>(i)] * static_cast<float>(sine_q31(p));
            p += phase_;  // (k + 1) times the fundamental's phase, modulo 2^32
        }
        phase_ += increment_;
        return m;
    }

    uint32_t phase_increment() const { return increment_; }

private:
    int count_ = 0;
    uint32_t increment_ = 0u;
    uint32_t phase_ = 0u;
    std::array<float, kMaxMainsHarmonics> scale_{};
};

}  // namespace piezoloop
