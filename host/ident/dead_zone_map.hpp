// A static monotone map as a superposition of one-sided dead-zone operators
// (Kuhnen 2003, "Modeling, identification and compensation of complex
// hysteretic nonlinearities: a modified Prandtl–Ishlinskii approach",
// European Journal of Control 9(4)):
//     f(x) = x + sum_i w_i max(x - d_i, 0),   d_1 < d_2 < ... ascending.
// f is the identity below d_1; its slope on segment i (between d_i and
// d_{i+1}) is 1 + w_1 + ... + w_i. With every slope > 0, f is strictly
// increasing and its inverse has the same form: thresholds f(d_i), weights
// 1/slope_i - 1/slope_{i-1}.
#pragma once

#include <string>
#include <vector>

#include "piezoloop/pi_model.hpp"
#include "piezoloop/plant.hpp"

namespace piezoloop::design {

struct DeadZoneMap {
    std::vector<double> thresholds;  // d_i, strictly ascending
    std::vector<double> weights;     // w_i, one per threshold

    double apply(double x) const;
    // Slopes of the segments: slopes()[0] = 1 below d_1, then one per threshold.
    std::vector<double> slopes() const;
    // "ok", or which slope is not > 0 (then there is no inverse).
    std::string monotonicity() const;
};

// The inverse map; throws std::invalid_argument if a slope is not > 0.
DeadZoneMap inverse(const DeadZoneMap& f);

// A stage's output map (plant.hpp) in double.
DeadZoneMap dead_zone_map(const OutputMap& m);

// g as a PiModel's input map (its dead zones, rounded to float); throws
// std::invalid_argument above kMaxDeadZones.
void set_input_map(const DeadZoneMap& g, PiModel& m);

}  // namespace piezoloop::design
