// The shipped xyz_flexure stage made linear, as tools/ref/coupled_stage_ref.py
// models it (tests/golden/coupled_stage_ref.json): each axis's hysteresis
// replaced by the linear gain the fixture names, ideal converters, no noise.
#pragma once

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "sim/scenario.hpp"
#include "test_support.hpp"

namespace piezoloop::test {

inline std::string configs_dir() {
    // Appended step by step: GCC 12 reports a false -Warray-bounds on the
    // operator+ of a literal here (GCC bug 105329).
    std::string d = PIEZOLOOP_GOLDEN_DIR;
    d += "/../../configs/";
    return d;
}

inline nlohmann::json stage_json(const std::string& name) {
    std::ifstream f(configs_dir() + "stages/" + name + ".json");
    return nlohmann::json::parse(f);
}

inline sim::Scenario linear_xyz_flexure(const nlohmann::json& ref) {
    nlohmann::json j = stage_json("xyz_flexure");
    nlohmann::json& axes = j["plant"]["axes"];
    for (size_t i = 0; i < axes.size(); ++i) {
        axes[i]["hysteresis"] = {{"kind", "none"}, {"gain_um_per_V", ref["linear_gain_um_per_V"][i]}};
        axes[i]["dac"]["bits"] = 0;
        axes[i]["adc"]["bits"] = 0;
        axes[i]["sensor"]["noise_rms"] = 0.0;
    }
    return sim::parse_scenario(j, configs_dir() + "stages");
}

}  // namespace piezoloop::test
