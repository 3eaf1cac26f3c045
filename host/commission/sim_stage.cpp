#include "commission/sim_stage.hpp"

#include <cmath>
#include <stdexcept>

#include "measure/frf_sim.hpp"
#include "measure/step_loops_sim.hpp"
#include "sim/build_case.hpp"
#include "sim/experiments.hpp"

namespace piezoloop::commission {

std::string SimStage::describe() const { return "the simulated stage of scenario " + s_.name; }

LoopFacts SimStage::loop() {
    return {s_.rate_Hz, false, s_.setup.position.full_scale, s_.setup.voltage.full_scale};
}

measure::MeasureBounds SimStage::bounds() { return measure::scenario_bounds(s_); }

void SimStage::rest() {
    carried_.rest(s_.limits, static_cast<float>(s_.rate_Hz), s_.plant.sensor.gain, kRestBetweenRuns_s);
}

measure::StepRun SimStage::step(const measure::StepRequest& r) {
    rest();
    return measure::run_step_sim(s_, nullptr, r, {}, &carried_);
}

measure::FrfRun SimStage::frf(const measure::FrfRequest& r) {
    if (r.closed && !loaded_) throw std::invalid_argument("closed loop: no controller loaded (track one first)");
    rest();
    measure::FrfRequest q = r;
    if (q.closed && std::isnan(q.setpoint_um)) q.setpoint_um = held_um_;
    return measure::run_frf_sim(s_, r.closed ? &*loaded_ : nullptr, q, {}, &carried_);
}

measure::LoopsRun SimStage::loops(const measure::LoopsRequest& r) {
    rest();
    return measure::run_loops_sim(s_, nullptr, r, {}, &carried_);
}

sim::CaseSpec controller_case(const Controller& k, sim::SampleType sample) {
    // lti feedback (e in µm, Tustin), the compensator as pi_compensator
    // feedforward, and the pre-filter.
    sim::CaseSpec cs;
    cs.name = cs.label = "commissioned";
    cs.sample = sample;
    cs.feedback.kind = "lti";
    cs.feedback.model = sim::LinearSpec{k.feedback, "commission", "commissioned.controller"};
    cs.feedback.path = "commissioned.feedback";
    if (k.prefilter) cs.prefilter = sim::LinearSpec{*k.prefilter, "commission", "commissioned.prefilter"};
    if (k.feedforward) {
        cs.feedforward.kind = "pi_compensator";
        cs.feedforward.pi = *k.feedforward;
        if (k.series) cs.feedforward.placement = "series";
        cs.feedforward.path = "commissioned.feedforward";
    }
    return cs;
}

TrackingRun SimStage::track(const Controller& k, const TrackRequest& t) {
    const sim::CaseSpec cs = controller_case(k, sample_);
    sim::BuildOptions bo;
    bo.check_realisation = false;
    const sim::BuiltCase b = sim::build_case(s_, cs, bo);
    loaded_ = cs;
    held_um_ = t.centre_um - 0.5 * t.range_um;
    sim::TrajectoryRequest w;
    w.waveform = Waveform::kTriangle;
    w.frequency_Hz = t.frequency_Hz;
    w.range_um = t.range_um;
    sim::RunOptions o = sim::plan_run(s_.rate_Hz, w, 0, false);
    o.wave.offset_um = static_cast<float>(t.centre_um);
    o.window_midpoint_um = t.centre_um;
    o.log_every = 1;
    o.carried = &carried_;
    rest();
    // The approach from where the stage is goes in front, as a board's
    // record puts it (the two periods stay the triangle's).
    sim::make_room_for_approach(b.model, o, carried_.started ? carried_.reading_um : 0.0f);
    const sim::RunResult r = sim::run_loop(b.model, o);
    TrackingRun out;
    out.e_max_um = r.tracking.e_max_um;
    out.e_rms_um = r.tracking.e_rms_um;
    out.e_max_pct = r.tracking.e_max_pct;
    out.e_rms_pct = r.tracking.e_rms_pct;
    out.hysteresis_pct = r.hysteresis_pct;
    out.trip = trip_reason_name(r.trip);
    const measure::MeasureBounds mb = bounds();
    out.diagnosis_inputs = {s_.rate_Hz, t.frequency_Hz, t.range_um, mb.limits.u_min_V, mb.limits.u_max_V,
                            mb.closed_range.min_um, mb.closed_range.max_um};
    const std::vector<double> rr(r.log.r_um.begin(), r.log.r_um.end()), yy(r.log.y_um.begin(), r.log.y_um.end()),
        uu(r.log.u_V.begin(), r.log.u_V.end());
    out.diagnosis = diagnose_tracking(rr, yy, uu, out.diagnosis_inputs);
    return out;
}

}  // namespace piezoloop::commission
