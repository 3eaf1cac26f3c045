// 16-bit converters: code <-> physical value <-> core sample.
//
// Every board's ADC (displacement) and DAC (piezo voltage) are modelled as
// signed 16-bit converters over a symmetric full scale FS: code c in
// [-32768, 32767] stands for c * FS / 32768, so one LSB is FS / 32768 (50 µm
// full scale: 1.53 nm; 12 V: 0.37 mV). The converter full scales are the
// pipeline's SignalScales (PipelineSetup.position / .voltage), so a code maps
// onto a Q31 sample by a shift and onto a float sample by one multiply.
//
// Rounding is IEEE-exact so that the firmware, the emulated stage and the
// host build of the self-test produce the same codes bit for bit:
//   physical -> code: nearest, ties away from zero (lroundf, which is exact
//                     everywhere: one VCVTA on the FPv5 boards, libm
//                     elsewhere), saturated; NaN -> 0
//   float sample -> code: the same on u * (32768 / FS)
//   Q31 sample -> code: (raw + 2^15) >> 16, saturated (ties towards +inf)
//   code -> float sample: c * (FS / 32768)   (exact when FS / 32768 is, e.g.
//                                              any FS with <= 24 significant bits)
//   code -> Q31 sample: c << 16               (exact)
#pragma once

#include <cstdint>
#include <type_traits>

#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"

namespace piezoloop::fw {

inline constexpr int32_t kCodeMin = -32768;
inline constexpr int32_t kCodeMax = 32767;
inline constexpr float kCodesPerFullScale = 32768.0f;

// x in LSB units (already scaled) -> code. The range tests come first so
// that lroundf only ever sees values it can represent (its result for
// NaN or beyond long is unspecified on the host).
inline int32_t code_from_lsb(float x) {
    if (!(x == x)) return 0;  // NaN
    if (x >= 32767.5f) return kCodeMax;
    if (x <= -32768.5f) return kCodeMin;
    return static_cast<int32_t>(__builtin_lroundf(x));
}

class Converter16 {
public:
    constexpr explicit Converter16(float full_scale)
        : full_scale_(full_scale),
          lsb_(full_scale / kCodesPerFullScale),
          per_unit_(kCodesPerFullScale / full_scale) {}

    constexpr float full_scale() const { return full_scale_; }
    constexpr float lsb() const { return lsb_; }

    int32_t code_from_physical(float x) const { return code_from_lsb(x * per_unit_); }
    constexpr float physical_from_code(int32_t c) const { return static_cast<float>(c) * lsb_; }

    // The core's sample type (float: physical units; Q31: normalised to the
    // same full scale, see piezoloop/sample.hpp).
    template <class T>
    constexpr T sample_from_code(int32_t c) const {
        if constexpr (std::is_same_v<T, float>) {
            return physical_from_code(c);
        } else {
            return Q31::from_raw(static_cast<int32_t>(static_cast<uint32_t>(c) << 16));
        }
    }
    template <class T>
    int32_t code_from_sample(T s) const {
        if constexpr (std::is_same_v<T, float>) {
            return code_from_physical(s);
        } else {
            const int32_t c = static_cast<int32_t>((int64_t{s.raw()} + 0x8000) >> 16);
            return c > kCodeMax ? kCodeMax : c;
        }
    }

private:
    float full_scale_;
    float lsb_;
    float per_unit_;
};

}  // namespace piezoloop::fw
