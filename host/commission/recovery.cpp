#include "commission/recovery.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "commission/sim_stage.hpp"
#include "sim/build_case.hpp"

namespace piezoloop::commission {

RecoveryRun saturation_recovery(const sim::Scenario& stage, const Controller& k, const RecoveryRequest& r) {
    if (!std::isfinite(r.range_um) || !(r.range_um > 0.0)) throw std::invalid_argument("range_um: must be > 0");
    if (!std::isfinite(r.bandwidth_Hz) || !(r.bandwidth_Hz > 0.0))
        throw std::invalid_argument("bandwidth_Hz: must be > 0");
    if (!std::isfinite(r.centre_um) || std::fabs(r.centre_um) > 1e4)
        throw std::invalid_argument("centre_um: must be finite and within +-1e4 um");
    if (!std::isfinite(r.beyond_um) || r.beyond_um < 0.0 || r.beyond_um > 1e4)
        throw std::invalid_argument("beyond_um: must be in [0, 1e4] um (0: 3 x range)");
    if (!std::isfinite(r.hold_s) || !(r.hold_s >= 0.01) || r.hold_s > 0.5)
        throw std::invalid_argument("hold_s: must be in [0.01, 0.5] s");

    RecoveryRun out;
    out.tolerance_um = 1e-3 * r.range_um;
    out.bound_s = 5.0 / r.bandwidth_Hz;

    // The step sequence in units of about 10 ms that divide the hold (the
    // table holds 256 levels).
    const int per_hold = std::max(1, static_cast<int>(std::lround(r.hold_s / 0.01)));
    const double unit_s = r.hold_s / per_hold;
    const int settle = static_cast<int>(std::ceil(std::max(0.3, out.bound_s) / unit_s));
    const int window = static_cast<int>(std::ceil(std::max(0.5, 2.0 * out.bound_s) / unit_s));
    const int n = settle + 2 * (per_hold + window);
    if (n > 256) throw std::invalid_argument("bandwidth_Hz: 5 / bandwidth too long for hold_s (more than 256 levels)");
    std::vector<float> table(static_cast<std::size_t>(n), 0.0f);
    std::fill_n(table.begin() + settle, per_hold, 1.0f);
    std::fill_n(table.begin() + settle + per_hold + window, per_hold, -1.0f);

    sim::BuildOptions bo;
    bo.check_realisation = false;
    const sim::BuiltCase b = sim::build_case(stage, controller_case(k, r.sample), bo);
    const double rate_Hz = b.model.setup.rate_Hz;
    const double period_s = n * unit_s;

    sim::RunOptions o;
    o.wave.waveform = Waveform::kSteps;
    o.wave.offset_um = static_cast<float>(r.centre_um);
    // Within the position full scale (the Q31 reference's; the float core
    // uses the same, so both run the same episode).
    const double room_um = 0.999 * (b.model.setup.position.full_scale - std::fabs(r.centre_um));
    if (!(room_um > 0.0)) throw std::invalid_argument("centre_um: must be inside the position full scale");
    o.wave.amplitude_um = static_cast<float>(std::min(r.beyond_um > 0.0 ? r.beyond_um : 3.0 * r.range_um, room_um));
    o.wave.frequency_Hz = static_cast<float>(1.0 / period_s);
    o.wave.cycles = 1;
    o.table = table;
    o.ticks = static_cast<uint64_t>(std::llround(period_s * rate_Hz));
    o.window_start = 0;
    o.window_midpoint_um = r.centre_um;
    o.log_start = 0;
    o.log_every = 1;
    o.hash = false;
    // The approach from the stage at rest to the centre goes in front; the
    // levels' ticks count from its end.
    sim::make_room_for_approach(b.model, o);
    const sim::RunResult res = sim::run_loop(b.model, o);
    out.trip = trip_reason_name(res.trip);
    out.wall_s = res.wall_s;

    const sim::RunLog& log = res.log;
    // What the loop holds: the reading without its noise and mains, (1 + gain
    // error) (x + offset) (stage_model.hpp), which is the displacement itself
    // for a sensor without offset or gain error.
    const SensorConfig& sc = b.model.stage.sensor;
    const auto held_um = [&](std::size_t i) {
        return (1.0 + double{sc.gain_error}) * (double{log.x_um[i]} + double{sc.offset_um});
    };
    const auto tick_at = [&](int level) {
        return static_cast<std::size_t>(o.approach_ticks) + static_cast<std::size_t>(std::llround(level * unit_s * rate_Hz));
    };
    const std::size_t first = tick_at(settle);  // the first episode's first tick
    const std::size_t last_100ms = first - std::min(first, static_cast<std::size_t>(0.1 * rate_Hz));
    for (std::size_t i = last_100ms; i < first; ++i)
        out.settled_error_um = std::max(out.settled_error_um, std::fabs(held_um(i) - r.centre_um));

    const LimitsConfig& lim = b.model.params.limits;
    const double volt_tol = 1e-4 * b.model.setup.voltage.full_scale;
    for (int ep = 0; ep < 2; ++ep) {
        RecoveryEpisode& e = out.episodes[static_cast<std::size_t>(ep)];
        e.direction = ep == 0 ? 1 : -1;
        const int start = settle + ep * (per_hold + window);
        const std::size_t k0 = tick_at(start), k1 = tick_at(start + per_hold), k2 = tick_at(start + per_hold + window);
        const double limit_V = ep == 0 ? lim.u_max_V : lim.u_min_V;
        std::size_t clamped = 0;
        for (std::size_t i = k0; i < k1; ++i)
            if (std::fabs(double{log.u_V[i]} - limit_V) < volt_tol) ++clamped;
        e.clamped_s = static_cast<double>(clamped) / rate_Hz;
        std::size_t last_outside = k1 - 1;  // none after the return yet
        for (std::size_t i = k1; i < k2; ++i)
            if (!(std::fabs(held_um(i) - r.centre_um) < out.tolerance_um)) last_outside = i;
        if (last_outside + 1 < k2) e.recovery_s = static_cast<double>(last_outside + 1 - k1) / rate_Hz;
    }
    return out;
}

}  // namespace piezoloop::commission
