#include "ident/dead_zone_map.hpp"

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace piezoloop::design {

double DeadZoneMap::apply(double x) const {
    double y = x;
    for (std::size_t i = 0; i < thresholds.size(); ++i) y += weights[i] * std::max(x - thresholds[i], 0.0);
    return y;
}

std::vector<double> DeadZoneMap::slopes() const {
    std::vector<double> s{1.0};
    for (double w : weights) s.push_back(s.back() + w);
    return s;
}

std::string DeadZoneMap::monotonicity() const {
    const std::vector<double> s = slopes();
    for (std::size_t i = 1; i < s.size(); ++i)
        if (!(s[i] > 0.0)) {
            std::ostringstream m;
            m << "slope " << s[i] << " above " << thresholds[i - 1] << " is not > 0: the map is not increasing";
            return m.str();
        }
    return "ok";
}

DeadZoneMap dead_zone_map(const OutputMap& m) {
    DeadZoneMap f;
    for (int i = 0; i < m.count; ++i) {
        f.thresholds.push_back(m.thresholds_um[static_cast<std::size_t>(i)]);
        f.weights.push_back(m.weights[static_cast<std::size_t>(i)]);
    }
    return f;
}

void set_input_map(const DeadZoneMap& g, PiModel& m) {
    const std::size_t n = g.thresholds.size();
    if (n > static_cast<std::size_t>(kMaxDeadZones)) throw std::invalid_argument("output_dead_zones: at most 8 in a compensator");
    m.dead_zones = static_cast<int>(n);
    for (std::size_t i = 0; i < n; ++i) {
        m.dead_zone_thresholds[i] = static_cast<float>(g.thresholds[i]);
        m.dead_zone_weights[i] = static_cast<float>(g.weights[i]);
    }
}

DeadZoneMap inverse(const DeadZoneMap& f) {
    if (const std::string m = f.monotonicity(); m != "ok") throw std::invalid_argument("output nonlinearity: " + m);
    const std::vector<double> s = f.slopes();
    DeadZoneMap g;
    for (std::size_t i = 0; i < f.thresholds.size(); ++i) {
        g.thresholds.push_back(f.apply(f.thresholds[i]));
        g.weights.push_back(1.0 / s[i + 1] - 1.0 / s[i]);
    }
    return g;
}

}  // namespace piezoloop::design
