// `piezoloop commission --scenario S --axes x,y[,z]`: a stage of coupled
// axes commissioned on the simulator, axis by axis, then decoupled
// (docs/commissioning.md, "Several axes"); on a board of axes
// (run_axes_commission_board, commission_axes_board.cpp) the same with the
// board's measurements:
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
#include "link/client.hpp"
#include "measure/mimo_frf_estimate.hpp"

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

// The coupled stage's response: open loop, about the middle of the command
// span, at a small signal, 1 % of the span peak: a hysteresis's play
// operators whose thresholds exceed the excursion then stay stuck, so the
// stage answers linearly at its initial slope (at 10 % the xy flexure's
// plays move, and their distortion, which the orthogonal multisines of
// every axis at once spread over all lines, swamps the few-percent
// coupling: y<-x read -18 dB instead of -30 dB). The static gain needs only
// the lowest lines, so the band is 10 to 100 Hz (ten lines share the
// amplitude) and eight periods are averaged: on the flexures the noise floor
// of an uncoupled pair is then near -60 dB, room for a 20 dB reduction of a
// -30 dB coupling.
inline constexpr double kFrfFrom_Hz = 10.0, kFrfTo_Hz = 100.0, kFrfAmplitude = 0.01;
inline constexpr int kFrfPeriods = 8;
// A pair is measured when its response stands this far above the noise at
// the low lines; below it, the pair has no coupling the measurement can see
// (an axis that does not move the other) and no reduction is asked of it.
inline constexpr double kMeasuredSnr_dB = 20.0;
inline constexpr double kCheckFrequency_Hz = 10.0;

// The travel of each axis (names: the stage's or the board's axes), after
// checking that --axes names each once (or is {"all"}); `what` names the
// stage in the messages. Throws std::invalid_argument naming the option.
std::map<std::string, double> axes_ranges(const AxesCommission& a, const std::vector<std::string>& names,
                                          const std::string& what);

// The low-frequency coupling per pair before (eb) and after (ea) the output
// matrix, the reduction, the pairs at the noise floor; `decoupled` when
// every measured pair dropped by kRequiredReduction_dB.
nlohmann::json coupling_change(const std::vector<std::string>& names, const measure::MimoFrfEstimate& eb,
                               const measure::MimoFrfEstimate& ea, bool& decoupled);

// report.md's tables: the coupling change's, each axis's commissioning
// (the sessions' summaries), and the cross-motion checks.
std::string coupling_table_md(const nlohmann::json& coupling);
std::string axes_table_md(const std::vector<std::string>& names, const std::map<std::string, double>& range_um,
                          const nlohmann::json& per_axis);
std::string cross_motion_table_md(const nlohmann::json& checks);

// Throws std::invalid_argument naming --axes / --range-um / --scenario
// before anything runs; as run_commission_session otherwise.
nlohmann::json run_axes_commission_board(hostlink::Client& c, const AxesCommission& a, bool save,
                                         const std::function<void(const std::string&)>& progress,
                                         const std::function<bool()>& stop_requested);
nlohmann::json run_axes_commission(const AxesCommission& a, const std::function<void(const std::string&)>& progress,
                                   const std::function<bool()>& stop_requested);

}  // namespace piezoloop::cli
