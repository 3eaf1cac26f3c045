// Generalised plants as JSON files, for `piezoloop design hinf`
// (docs/synthesis.md, 'Plant file'):
//
//   {"A": [[...], ...],  n rows of n numbers
//    "B": [[...], ...],  n rows of (w + u) numbers
//    "C": [[...], ...],  (z + y) rows of n numbers
//    "D": [[...], ...],  (z + y) rows of (w + u) numbers
//    "partition": {"w": 1, "u": 1, "z": 2, "y": 1}}
//
// Inputs are ordered [w; u] and outputs [z; y] (the controller reads the
// last y outputs and drives the last u inputs, as Octave's hinfsyn with
// nmeas = y, ncon = u). Continuous time, s in rad/s. Documentation keys
// ("name", "description", "source", "comment", "units", "_..."), are
// ignored; any other key is an error. Errors name the field:
// "P.json: plant.B[2]: 3 numbers, the partition says w + u = 2".
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "synth/hinfsyn.hpp"

namespace piezoloop::design {

inline constexpr int kMaxPlantStates = 200;
inline constexpr int kMaxPlantSignals = 50;

GeneralisedPlant parse_plant(const nlohmann::json& j, const std::string& path = "plant");
GeneralisedPlant load_plant_file(const std::string& filename);

// Matrices as arrays of rows.
nlohmann::json matrix_json(const Eigen::MatrixXd& m);
nlohmann::json state_space_json(const StateSpace& g);

}  // namespace piezoloop::design
