// A scenario's stage as commissioning sees it (commission/stage_access.hpp):
// measured by the simulator, its cases and models never read. A closed-loop
// frequency response runs the controller `track` loaded last.
// Also the identified stage a prediction runs on (commission/identified_stage).
#pragma once

#include <optional>

#include "commission/stage_access.hpp"
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

private:
    sim::Scenario s_;
    sim::SampleType sample_;
    std::optional<sim::CaseSpec> loaded_;  // what track() ran
};

}  // namespace piezoloop::commission
