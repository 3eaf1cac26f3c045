// `piezoloop commission --scenario S --axes x,y[,z]`: a stage of coupled
// axes commissioned on the simulator, axis by axis, then decoupled
// (docs/commissioning.md, "Several axes"):
//
//   1. each axis commissioned as a single axis (commission_session.hpp) with
//      the other axes holding still, which is exactly what it sees then (a
//      coupling path adds another axis's motion to its position; nothing
//      of its own motion comes back): DIR/<axis>/ holds its report;
//   2. the open-loop n x n frequency response of the coupled stage
//      (measure/mimo_frf_sim.hpp, orthogonal multisines of 1 % of the span
//      about its middle, 10 to 100 Hz), its low-frequency coupling per pair,
//      and the static decoupling output matrix D = G0^-1 diag(G0)
//      (measure/static_decoupling.hpp);
//   3. the response measured again through D: the coupling left, and the
//      reduction per pair;
//   4. the commissioned controllers and D as a case of the coupled stage
//      ("commissioned"; "commissioned_without_decoupling" beside it), and on
//      it a 10 Hz triangle over each axis's range with the others holding
//      their centres: the driven axis's tracking and how far the held axes
//      move, with and without D.
//
// DIR/scenario.json is the coupled stage with those two cases;
// DIR/report.md the figures. The result is "verified" when every axis
// verified; "decoupled" when the low-frequency coupling of every pair the
// measurement sees (20 dB above its noise) dropped by at least
// kRequiredReduction_dB.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commission/commission.hpp"

namespace piezoloop::cli {

struct AxesCommission {
    std::string scenario;                     // a scenario of two or three coupled axes
    std::string out;                          // DIR
    std::vector<std::string> axes;            // every axis of the stage, once each; {"all"}: all of them
    std::map<std::string, double> range_um;   // per axis: the travel its loop must hold
    double range_every_um = 0.0;              // > 0: the travel of the axes range_um does not name
    commission::CommissionRequest request;    // the rest of each axis's request (range_um set per axis)
};

inline constexpr double kRequiredReduction_dB = 20.0;

// Throws std::invalid_argument naming --axes / --range-um / --scenario
// before anything runs; as run_commission_session otherwise.
nlohmann::json run_axes_commission(const AxesCommission& a, const std::function<void(const std::string&)>& progress,
                                   const std::function<bool()>& stop_requested);

}  // namespace piezoloop::cli
