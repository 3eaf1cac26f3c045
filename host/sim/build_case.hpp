// From a scenario's case to what the loop runs (LoopModel): the stage in
// both fidelities, the core's PipelineParams (continuous controllers
// discretised to biquad sections at the loop rate, hysteresis inverses
// computed, a Dahl compensator identified from the stage's own loops), and
// the notes a report needs to say how each case was made.
#pragma once

#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ident/dahl_fit.hpp"
#include "sim/closed_loop.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::sim {

struct BuildOptions {
    double reference_frequency_Hz = 0.0;  // for the RC period "auto"
    int substeps = 10;                    // double fidelity: sub-steps per tick
    bool check_realisation = true;        // run lti/realisation on the controller (slow for slow poles)
    // Several axes (build_multi_axis_case): each axis's reference frequency,
    // in place of reference_frequency_Hz when given (one entry an axis).
    std::vector<double> axis_reference_frequency_Hz;
};

// A Dahl compensator identified from the stage (docs/models.md, 'Dahl model and
// feedforward', 'Identification').
struct DahlIdentification {
    DahlParams params{};           // as the core runs it (command V -> µm)
    design::DahlFitResult fit;
    size_t samples = 0;
    std::string data;              // what the loops were
};

struct BuiltCase {
    LoopModel model;
    std::vector<std::string> notes;
    std::optional<DahlIdentification> dahl;
    int plant_sections = 0, controller_sections = 0;
};

// Caches identifications so that every experiment of a case uses the same one.
class DahlCache {
public:
    const DahlIdentification& get(const Scenario& s, const CaseSpec& c, int substeps);

private:
    std::mutex mutex_;
    std::map<std::string, DahlIdentification> done_;
};

// Throws ScenarioError / std::invalid_argument naming the field.
BuiltCase build_case(const Scenario& s, const CaseSpec& c, const BuildOptions& o, DahlCache* cache = nullptr);

// The float stage of one axis: its plant with hysteresis h, the dynamics
// discretised at rate_Hz (sections: how many biquads they took). Throws
// ScenarioError / std::invalid_argument naming the field.
StageConfig float_stage_config(const PlantSpec& p, const HysteresisSpec& h, double rate_Hz, int* sections = nullptr);

// The stage of a case alone (its hysteresis override applied), both fidelities.
void build_stage(const Scenario& s, const CaseSpec* c, int substeps, LoopModel& out, int* sections = nullptr);

// The analytic inverse of a hysteresis as a compensator from r (µm) to the
// command u (V) at the amplifier input (docs/models.md, 'Analytic PI inverse', on the factored form; any
// constant offset of the affine input is dropped and reported in `note`).
PiModel inverse_compensator(const HysteresisSpec& h, double amplifier_gain, std::string& note);

}  // namespace piezoloop::sim
