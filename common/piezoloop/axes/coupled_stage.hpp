// A stage of one to three coupled axes (an XY flexure, with or without a Z
// stack), docs/models.md, 'Coupled axes': every axis is a whole StageModel
// (its own DAC, amplifier, hysteresis, dynamics, sensor and ADC), and a
// command on one axis also moves the others through coupling paths. A path
// from axis j to axis i is a discrete filter C_ij (biquad sections at the
// loop rate) from j's displacement x_j to i's position. Per sample, in this
// fixed order:
//
//   x_j = actuate_j(u_j)                     j = 0 .. n-1 (DAC, amplifier, plant)
//   p_i = x_i + sum_k C_k(x_from(k))         paths k in configuration order
//   reading_i = sense_i(p_i)                 i = 0 .. n-1 (sensor, ADC)
//
// The sensor of axis i reads p_i: the true position of that axis. The paths
// act on the axes' own displacements x_j, not on positions already moved by
// coupling, so there is no algebraic loop and no chain of couplings.
// Float, freestanding (no heap, no libm) and deterministic like the rest of
// the core: one axis with no path gives StageModel's bits exactly.
#pragma once

#include <array>
#include <cstdint>

#include "piezoloop/biquad.hpp"
#include "piezoloop/stage_model.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

inline constexpr int kMaxStageAxes = 3;
inline constexpr int kMaxCouplingPaths = kMaxStageAxes * (kMaxStageAxes - 1);  // every ordered pair
inline constexpr int kMaxCouplingSections = 2;

// One coupling path: axis `from`'s displacement (µm) -> a contribution to
// axis `to`'s position (µm), through `sections` biquad sections at the loop
// rate (unit: µm/µm).
struct CouplingPath {
    int from = 0;
    int to = 1;
    int sections = 0;
    std::array<SosSection, kMaxCouplingSections> filter{};
};

struct CoupledStageConfig {
    int axes = 1;                                      // 1 .. kMaxStageAxes
    std::array<StageConfig, kMaxStageAxes> axis{};     // all at the same rate_Hz
    int paths = 0;                                     // 0 .. kMaxCouplingPaths
    std::array<CouplingPath, kMaxCouplingPaths> coupling{};
};

namespace detail {

// Field paths as string literals (a Status holds no allocated text);
// same_text is biquad.hpp's.
inline constexpr const char* kAxisGroups[kMaxStageAxes][6] = {
    {"axis[0]", "axis[0].dac", "axis[0].adc", "axis[0].amplifier", "axis[0].sensor", "axis[0].plant"},
    {"axis[1]", "axis[1].dac", "axis[1].adc", "axis[1].amplifier", "axis[1].sensor", "axis[1].plant"},
    {"axis[2]", "axis[2].dac", "axis[2].adc", "axis[2].amplifier", "axis[2].sensor", "axis[2].plant"},
};
inline constexpr const char* kCouplingGroups[kMaxCouplingPaths][2] = {
    {"coupling[0]", "coupling[0].filter"}, {"coupling[1]", "coupling[1].filter"},
    {"coupling[2]", "coupling[2].filter"}, {"coupling[3]", "coupling[3].filter"},
    {"coupling[4]", "coupling[4].filter"}, {"coupling[5]", "coupling[5].filter"},
};

// A StageModel's error, placed under axis[i] (its own group, if any, kept).
inline constexpr Status in_axis(int i, Status s) {
    const char* const* g = kAxisGroups[i];
    const char* group = g[0];
    for (int k = 1; k < 6; ++k)
        if (s.group != nullptr && same_text(s.group, g[k] + 8)) group = g[k];  // g[k] + 8: after "axis[i]."
    s.group = group;
    return s;
}

}  // namespace detail

class CoupledStage {
public:
    // Checks everything first; on error names the field (e.g. group
    // "coupling[1]", field "to") and changes nothing.
    Status configure(const CoupledStageConfig& c) {
        if (c.axes < 1 || c.axes > kMaxStageAxes) return error("axes", "must be in [1, 3]");
        if (c.paths < 0 || c.paths > kMaxCouplingPaths) return error("paths", "must be in [0, 6]");
        for (int i = 0; i < c.axes; ++i) {
            const StageConfig& a = c.axis[static_cast<std::size_t>(i)];
            if (i > 0 && !(a.rate_Hz == c.axis[0].rate_Hz))
                return detail::in_axis(i, error("rate_Hz", "must equal axis[0].rate_Hz (one loop rate)"));
            // One axis at a time: a board's boot stack holds one StageModel.
            StageModel probe;
            if (const Status s = probe.configure(a); !s.ok()) return detail::in_axis(i, s);
        }
        std::array<BiquadCascade<float, kMaxCouplingSections>, kMaxCouplingPaths> filter{};
        for (int k = 0; k < c.paths; ++k) {
            const CouplingPath& p = c.coupling[static_cast<std::size_t>(k)];
            const char* group = detail::kCouplingGroups[k][0];
            if (p.from < 0 || p.from >= c.axes) return in_group(group, error("from", "must be an axis: in [0, axes)"));
            if (p.to < 0 || p.to >= c.axes) return in_group(group, error("to", "must be an axis: in [0, axes)"));
            if (p.to == p.from) return in_group(group, error("to", "must differ from `from` (no path from an axis to itself)"));
            for (int m = 0; m < k; ++m) {
                const CouplingPath& q = c.coupling[static_cast<std::size_t>(m)];
                if (q.from == p.from && q.to == p.to)
                    return in_group(group, error("to", "a path between these two axes in this direction is given already"));
            }
            if (p.sections < 1 || p.sections > kMaxCouplingSections)
                return in_group(group, error("sections", "must be in [1, 2]"));
            // A stage model, as the plant's dynamics: DF2T wherever its
            // coefficients hold (biquad.hpp).
            if (const Status s = filter[static_cast<std::size_t>(k)].configure(p.filter.data(), p.sections, {}, {},
                                                                                FormChoice::kCoefficients);
                !s.ok())
                return in_group(detail::kCouplingGroups[k][1], s);
        }
        config_ = c;
        for (int i = 0; i < c.axes; ++i) {
            const Status s = axis_[static_cast<std::size_t>(i)].configure(c.axis[static_cast<std::size_t>(i)]);
            (void)s;  // accepted above
        }
        filter_ = filter;
        reset();
        return ok_status();
    }

    void reset() {
        for (int i = 0; i < config_.axes; ++i) axis_[static_cast<std::size_t>(i)].reset();
        for (int k = 0; k < config_.paths; ++k) filter_[static_cast<std::size_t>(k)].reset();
        x_um_ = {};
        p_um_ = {};
    }

    // One sample: the commands (V) of axes() axes in, their ADC readings (in
    // each sensor's units) out.
    void step(const float* u_V, float* readings) {
        const int n = config_.axes;
        for (int j = 0; j < n; ++j) x_um_[static_cast<std::size_t>(j)] = axis_[static_cast<std::size_t>(j)].actuate(u_V[j]);
        p_um_ = x_um_;
        for (int k = 0; k < config_.paths; ++k) {
            const CouplingPath& p = config_.coupling[static_cast<std::size_t>(k)];
            const float c = filter_[static_cast<std::size_t>(k)].apply(x_um_[static_cast<std::size_t>(p.from)]);
            p_um_[static_cast<std::size_t>(p.to)] = p_um_[static_cast<std::size_t>(p.to)] + c;
        }
        for (int i = 0; i < n; ++i) readings[i] = axis_[static_cast<std::size_t>(i)].sense(p_um_[static_cast<std::size_t>(i)]);
    }

    int axes() const { return config_.axes; }
    // Axis i's own displacement (before coupling), last sample.
    float displacement_um(int i) const { return x_um_[static_cast<std::size_t>(i)]; }
    // Axis i's true position (what its sensor reads), last sample.
    float position_um(int i) const { return p_um_[static_cast<std::size_t>(i)]; }
    float piezo_voltage_V(int i) const { return axis_[static_cast<std::size_t>(i)].piezo_voltage_V(); }
    const StageModel& axis(int i) const { return axis_[static_cast<std::size_t>(i)]; }
    const CoupledStageConfig& config() const { return config_; }

private:
    CoupledStageConfig config_{};
    std::array<StageModel, kMaxStageAxes> axis_{};
    std::array<BiquadCascade<float, kMaxCouplingSections>, kMaxCouplingPaths> filter_{};
    std::array<float, kMaxStageAxes> x_um_{};
    std::array<float, kMaxStageAxes> p_um_{};
};

}  // namespace piezoloop
