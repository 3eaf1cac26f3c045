// From a scenario's plant to the core's stage of coupled axes
// (common/piezoloop/axes/coupled_stage.hpp, docs/models.md, 'Coupled axes'):
// every axis's float stage as the single-axis simulator builds it, and every
// coupling path's C(s) discretised at the loop rate the way the plant's
// dynamics are (ZOH advanced by one sample by default).
#pragma once

#include "piezoloop/axes/coupled_stage.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::sim {

// One axis (no path) for a single-axis plant, else plant.axes in order and
// plant.coupling in order. Throws ScenarioError / std::invalid_argument
// naming the field (e.g. "plant.coupling[1]: ...").
CoupledStageConfig coupled_stage_config(const Scenario& s);

// The sections of one coupling path at the scenario's loop rate.
std::vector<SosSection> coupling_sections(const CouplingSpec& c, double rate_Hz);

}  // namespace piezoloop::sim
