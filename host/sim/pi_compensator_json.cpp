#include "sim/pi_compensator_json.hpp"

namespace piezoloop::sim {

nlohmann::json pi_compensator_json(const PiModel& c) {
    nlohmann::json k = {{"kind", "pi_compensator"}, {"thresholds_um", nlohmann::json::array()},
                        {"weights_V_per_um", nlohmann::json::array()}, {"p0_V_per_um", c.p0}};
    for (int j = 0; j < c.count; ++j) {
        k["thresholds_um"].push_back(c.thresholds[static_cast<unsigned>(j)]);
        k["weights_V_per_um"].push_back(c.weights[static_cast<unsigned>(j)]);
    }
    if (c.input_offset != 0.0f) k["input_offset_um"] = c.input_offset;
    if (c.dead_zones > 0) {
        nlohmann::json d = {{"thresholds_um", nlohmann::json::array()}, {"weights", nlohmann::json::array()}};
        for (int i = 0; i < c.dead_zones; ++i) {
            d["thresholds_um"].push_back(c.dead_zone_thresholds[static_cast<unsigned>(i)]);
            d["weights"].push_back(c.dead_zone_weights[static_cast<unsigned>(i)]);
        }
        k["dead_zones"] = d;
    }
    return k;
}

}  // namespace piezoloop::sim
