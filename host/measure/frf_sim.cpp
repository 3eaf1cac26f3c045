#include "measure/frf_sim.hpp"

#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "piezoloop/pipeline.hpp"
#include "piezoloop/reference_run.hpp"
#include "sim/build_case.hpp"
#include "sim/loop_kernel.hpp"
#include "status_text.hpp"
#include "options/option_checks.hpp"

namespace piezoloop::measure {

namespace {

using options::refuse;

template <class T>
FrfRun run_with(const sim::LoopModel& m, const FrfRequest& r, const FrfPlan& plan, double setpoint_um,
                const std::function<void(double)>& progress, sim::CarriedStage* carried) {
    using PipelineT = Pipeline<T, sim::kSimRcCapacity, 4, 1024, kSimExcitationCapacity>;
    auto pipe = std::make_unique<PipelineT>(m.setup);
    auto fail = [](const char* what, const Status& st) {
        throw std::invalid_argument(std::string(what) + ": " + describe(st));
    };
    if (const Status st = pipe->stage(m.params); !st.ok()) fail("controller", st);
    if (r.closed) (void)pipe->set_setpoint(m.setup.position.to_sample<T>(static_cast<float>(setpoint_um)));
    if (const Status st = pipe->start_excitation(excitation_config(plan, r)); !st.ok()) fail("excitation", st);
    pipe->arm();

    StageModel stage;
    StageConfig sc = m.stage;
    sc.rate_Hz = m.setup.rate_Hz;
    if (const Status st = stage.configure(sc); !st.ok()) fail("plant", st);

    FrfRun run;
    run.plan = plan;
    const std::size_t n_meas = static_cast<std::size_t>(plan.ticks - plan.measured_start);
    std::vector<double> u, y, d;
    u.reserve(n_meas);
    y.reserve(n_meas);
    if (r.closed) d.reserve(n_meas);
    uint32_t clip_at_start = 0;
    auto clip_count = [&] { return pipe->limiter().clamped_samples() + pipe->limiter().slew_limited_samples(); };
    const uint64_t progress_every = uint64_t{1} << 15;
    auto observe = [&](const sim::TickView& v, const TickSignals<T>& sig, const StageModel&) {
        if (v.k >= plan.measured_start) {
            u.push_back(static_cast<double>(v.u_V));
            y.push_back(static_cast<double>(v.y_um));
            if (r.closed) d.push_back(static_cast<double>(m.setup.voltage.to_physical(sig.d)));
        }
        if (v.k + 1 == plan.measured_start) clip_at_start = clip_count();
        if (progress && (v.k + 1) % progress_every == 0)
            progress(static_cast<double>(v.k + 1) / static_cast<double>(plan.ticks));
    };
    reference::LogHash hash;
    const auto t0 = std::chrono::steady_clock::now();
    sim::run_ticks<T>(*pipe, stage, m.stage.sensor.gain, plan.ticks, &hash, observe, carried);
    run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (progress) progress(1.0);
    run.log_hash = hash.value();
    const uint32_t clip_end = clip_count();
    run.clipped_transient = plan.measured_start == 0 ? 0 : clip_at_start;
    run.clipped_samples = clip_end - clip_at_start;
    run.trip = trip_reason_name(pipe->limiter().trip_reason());
    analyse_frf(r, u, y, d, run);
    return run;
}

}  // namespace

FrfPlan plan_frf(const sim::Scenario& s, const FrfRequest& r) {
    return plan_frf(s.rate_Hz, s.limits, kSimExcitationCapacity, r, "scenario's");
}

FrfRun run_frf_sim(const sim::Scenario& s, const sim::CaseSpec* case_spec, const FrfRequest& r,
                   const std::function<void(double)>& progress, sim::CarriedStage* carried) {
    const FrfPlan plan = plan_frf(s, r);
    sim::LoopModel m;
    if (r.closed) {
        if (!case_spec) refuse("--case", "closed loop needs the case whose controller closes it");
        sim::BuildOptions bo;
        bo.check_realisation = false;
        m = sim::build_case(s, *case_spec, bo).model;
    } else {
        sim::build_stage(s, case_spec, 10, m);
        m.setup = s.setup;
        m.params = PipelineParams{};
        m.params.limits = s.limits;
        m.sample = case_spec ? case_spec->sample : sim::SampleType::kFloat;
    }
    const double setpoint_um = std::isnan(r.setpoint_um) ? r.bias_V * s.command_um_per_V() : r.setpoint_um;
    return m.sample == sim::SampleType::kQ31 ? run_with<Q31>(m, r, plan, setpoint_um, progress, carried)
                                             : run_with<float>(m, r, plan, setpoint_um, progress, carried);
}

}  // namespace piezoloop::measure
