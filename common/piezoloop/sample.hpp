// The two sample types of the core and how physical values map onto them.
//
// A float sample *is* the physical value (µm, V). A Q31 sample is the physical
// value divided by a full scale (e.g. 40 µm or 150 V), so it lies in [-1, 1).
// Blocks are configured from physical parameters plus the scales of their
// input and output; the Q31 specialisation folds the scales into its
// coefficients once, at configure time, never in the tick.
#pragma once

#include <type_traits>

#include "piezoloop/q31.hpp"

namespace piezoloop {

template <class T>
inline constexpr bool is_sample_type_v = std::is_same_v<T, float> || std::is_same_v<T, Q31>;

// Physical <-> sample conversion for one signal.
struct SignalScale {
    float full_scale = 1.0f;  // physical value that maps to Q31 full scale

    template <class T>
    constexpr T to_sample(float physical) const {
        if constexpr (std::is_same_v<T, float>) {
            return physical;
        } else {
            return Q31::from_float(physical / full_scale);
        }
    }
    template <class T>
    constexpr float to_physical(T sample) const {
        if constexpr (std::is_same_v<T, float>) {
            return sample;
        } else {
            return sample.to_float() * full_scale;
        }
    }
    // Factor that turns a physical gain (out per in) into the gain between
    // the samples: physical_gain * in.full_scale / out.full_scale for Q31,
    // unchanged for float.
    template <class T>
    static constexpr double sample_gain(double physical_gain, SignalScale in, SignalScale out) {
        if constexpr (std::is_same_v<T, float>) {
            return physical_gain;
        } else {
            return physical_gain * static_cast<double>(in.full_scale) /
                   static_cast<double>(out.full_scale);
        }
    }
};

template <class T>
constexpr T sample_zero() {
    if constexpr (std::is_same_v<T, float>) return 0.0f; else return Q31::from_raw(0);
}

// Sample-type generic max/min so blocks written once work for both types.
constexpr float max(float a, float b) { return a < b ? b : a; }
constexpr float min(float a, float b) { return b < a ? b : a; }

}  // namespace piezoloop
