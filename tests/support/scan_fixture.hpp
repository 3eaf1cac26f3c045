// Shared by the scan tests (tests/common/scan/): a ScanConfig from a case of
// tests/golden/scan_ref.json (tools/ref/scan_ref.py), and a generator run
// recorded tick by tick.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "piezoloop/scan/scan_generator.hpp"
#include "test_support.hpp"

namespace piezoloop::test {

// The case of scan_ref.json named `name`.
inline nlohmann::json scan_case(const std::string& name) {
    const nlohmann::json all = load_golden("scan_ref");
    for (const auto& c : all["cases"]) {
        if (c["name"] == name) return c;
    }
    return {};
}

inline ScanConfig scan_config_of(const nlohmann::json& j) {
    ScanConfig c;
    const std::string p = j["pattern"];
    c.pattern = p == "raster" ? ScanPattern::kRaster
              : p == "spiral" ? ScanPattern::kSpiral
              : p == "lissajous" ? ScanPattern::kLissajous
                                 : ScanPattern::kCycloid;
    auto f = [&](const char* key, float& field) { if (j.contains(key)) field = j[key].get<float>(); };
    auto u = [&](const char* key, uint32_t& field) { if (j.contains(key)) field = j[key].get<uint32_t>(); };
    f("sample_rate_Hz", c.sample_rate_Hz);
    f("centre_x_um", c.centre_x_um);
    f("centre_y_um", c.centre_y_um);
    f("rotation_deg", c.rotation_deg);
    u("frames", c.frames);
    u("pixels_per_line", c.pixels_per_line);
    f("size_x_um", c.size_x_um);
    f("size_y_um", c.size_y_um);
    u("lines_per_frame", c.lines_per_frame);
    f("line_rate_Hz", c.line_rate_Hz);
    f("retrace_speed_factor", c.retrace_speed_factor);
    f("overscan_fraction", c.overscan_fraction);
    f("turnaround_s", c.turnaround_s);
    if (j.contains("slow_axis")) c.slow_axis = j["slow_axis"] == "ramp" ? SlowAxis::kRamp : SlowAxis::kStaircase;
    if (j.contains("bidirectional")) c.bidirectional = j["bidirectional"].get<bool>();
    if (j.contains("fast_axis")) c.fast_axis = j["fast_axis"] == "sine" ? FastAxis::kSine : FastAxis::kTriangle;
    if (j.contains("spiral_mode"))
        c.spiral_mode = j["spiral_mode"] == "clv" ? SpiralMode::kConstantLinearVelocity
                                                  : SpiralMode::kConstantAngularVelocity;
    f("radius_um", c.radius_um);
    u("turns", c.turns);
    f("turn_rate_Hz", c.turn_rate_Hz);
    f("linear_speed_um_s", c.linear_speed_um_s);
    f("frequency_x_Hz", c.frequency_x_Hz);
    f("frequency_y_Hz", c.frequency_y_Hz);
    f("phase_y_deg", c.phase_y_deg);
    u("turns_per_line", c.turns_per_line);
    return c;
}

// A run: each tick's reference in µm (Q31 scaled back) and sync word.
struct ScanRun {
    std::vector<double> x, y, z;
    std::vector<uint32_t> sync;
    std::size_t size() const { return x.size(); }
    // Ticks with any of the bits set.
    std::vector<std::size_t> ticks_with(uint32_t bits) const {
        std::vector<std::size_t> t;
        for (std::size_t i = 0; i < sync.size(); ++i) {
            if (sync[i] & bits) t.push_back(i);
        }
        return t;
    }
};

// Runs g for `ticks` ticks (0: until done()).
template <class T>
ScanRun run_scan(ScanGenerator<T>& g, std::size_t ticks = 0, SignalScale sx = {}, SignalScale sy = {},
                 SignalScale sz = {}) {
    ScanRun r;
    if (!g.configured()) return r;
    for (std::size_t n = 0; ticks == 0 ? !g.done() : n < ticks; ++n) {
        const ScanPoint<T> p = g.step();
        r.x.push_back(sx.to_physical(p.x));
        r.y.push_back(sy.to_physical(p.y));
        r.z.push_back(sz.to_physical(p.z));
        r.sync.push_back(p.sync);
        if (n > 50000000) break;  // a run that never ends fails the caller's checks
    }
    return r;
}

// One float ulp at |v|.
inline double float_ulp(double v) {
    const float a = static_cast<float>(std::fabs(v));
    return static_cast<double>(std::nextafter(a, INFINITY) - a);
}

}  // namespace piezoloop::test
