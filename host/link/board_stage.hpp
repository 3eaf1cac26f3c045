// A board as commissioning sees it (commission/stage_access.hpp): open-loop
// steps and frequency responses through the measurement sessions
// (link/measure_session), and a controller verified by loading it as the
// board's feedback, feedforward and reference pre-filter (repetitive control
// off, the board's limits group as it is) and recording a centred triangle
// (link/record_session). `piezoloop --device ADDR commission`. On a board of
// axes it is the axis of MeasureOptions::axis; the others hold.
#pragma once

#include "commission/stage_access.hpp"
#include "link/client.hpp"
#include "link/measure_session.hpp"

namespace piezoloop::hostlink {

class BoardStage : public commission::StageAccess {
public:
    BoardStage(Client& c, MeasureOptions o) : c_(c), o_(std::move(o)) {}
    std::string describe() const override;
    commission::LoopFacts loop() override;
    measure::MeasureBounds bounds() override { return board_bounds(c_, o_.axis); }
    measure::StepRun step(const measure::StepRequest& r) override { return run_step_device(c_, r, o_); }
    measure::FrfRun frf(const measure::FrfRequest& r) override { return run_frf_device(c_, r, o_).run; }
    measure::LoopsRun loops(const measure::LoopsRequest& r) override { return run_loops_device(c_, r, o_); }
    commission::TrackingRun track(const commission::Controller& k, const commission::TrackRequest& t) override;

private:
    Client& c_;
    MeasureOptions o_;
};

// The controller (continuous, e in µm -> u in V) as the board's feedback
// group of `axis`: Tustin sections at its loop rate, scaled for the axis's
// Q31 full scales on a Q31 board.
link::FeedbackParams feedback_group(const design::Zpk& controller, const link::HelloReply& h, bool series = false,
                                    uint8_t axis = 0);

}  // namespace piezoloop::hostlink
