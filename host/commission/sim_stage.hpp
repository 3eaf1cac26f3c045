// A scenario's stage as commissioning sees it (commission/stage_access.hpp):
// measured by the simulator, its cases and models never read. A closed-loop
// frequency response runs the controller `track` loaded last and, unless the
// request names a setpoint, holds where that triangle stopped: its minimum,
// where a board's triangle stops by itself (link/board_stage.cpp) and its
// loop then holds.
// Also the identified stage a prediction runs on (commission/identified_stage).
// As on a board, the stage carries on from one run to the next (its
// hysteresis's memory, its position), with the disarmed loop's ramp to the
// safe command and a rest of kRestBetweenRuns_s between them
// (sim/carried_stage.hpp); state() and set_state() save and restore that.
#pragma once

#include <optional>

#include "commission/stage_access.hpp"
#include "sim/carried_stage.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::commission {

// A controller as a scenario's case named "commissioned", in the core's
// sample type `sample`: what track() runs (and DIR/scenario.json's case).
sim::CaseSpec controller_case(const Controller& k, sim::SampleType sample);

class SimStage : public StageAccess {
public:
    explicit SimStage(sim::Scenario s, sim::SampleType sample = sim::SampleType::kFloat) : s_(std::move(s)), sample_(sample) {}
    std::string describe() const override;
    LoopFacts loop() override;
    measure::MeasureBounds bounds() override;
    measure::StepRun step(const measure::StepRequest& r) override;
    measure::FrfRun frf(const measure::FrfRequest& r) override;
    measure::LoopsRun loops(const measure::LoopsRequest& r) override;
    TrackingRun track(const Controller& k, const TrackRequest& t) override;

    static constexpr double kRestBetweenRuns_s = 0.1;
    const sim::CarriedStage& state() const { return carried_; }
    void set_state(const sim::CarriedStage& s) { carried_ = s; }

private:
    // The disarmed loop between two runs.
    void rest();

    sim::Scenario s_;
    sim::SampleType sample_;
    std::optional<sim::CaseSpec> loaded_;  // what track() ran
    double held_um_ = 0.0;                 // where that triangle stopped
    sim::CarriedStage carried_;
};

}  // namespace piezoloop::commission
