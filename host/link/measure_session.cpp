#include "link/measure_session.hpp"
#include "link/recorded_signals.hpp"

#include <algorithm>
#include <chrono>
#include <optional>
#include <stdexcept>

namespace piezoloop::hostlink {

ControllerGroups read_controller(Client& c, uint8_t axis) {
    return {c.get<link::FeedforwardParams>(axis), c.get<link::FeedbackParams>(axis), c.get<link::RepetitiveParams>(axis)};
}

void write_controller(Client& c, const ControllerGroups& g, uint8_t axis) {
    c.set(g.ff, axis);
    c.set(g.fb, axis);
    c.set(g.rc, axis);
}

void restore_recorder(Client& c, const link::RecorderParams& before) {
    if (!(c.get<link::RecorderParams>() == before)) c.set(before);
}

namespace {

// An axis of the board (std::invalid_argument naming --axis otherwise).
void check_axis(Client& c, uint8_t axis) {
    if (axis >= c.info().axis_count)
        throw std::invalid_argument("--axis: this board has " + std::to_string(c.info().axis_count) + " axes");
}

const char* axis_letter(std::size_t a) { return a == 0 ? "x" : a == 1 ? "y" : "z"; }

// The board must be free and able to move before anything is changed: no
// wave, stream or excitation on any axis, no axis tripped (arming arms
// every axis).
void check_ready(Client& c, bool closed, const link::StatusReply& st, uint8_t axis) {
    const std::size_t n = std::min<std::size_t>(st.axis_count, link::kMaxLinkAxes);
    const auto on = [&](std::size_t a) { return n > 1 ? " on axis " + std::string(axis_letter(a)) : std::string(); };
    for (std::size_t a = 0; a < n; ++a) {
        if (st.axis_wave_running[a] || st.axis_excitation_running[a])
            throw std::invalid_argument(std::string("the board is running a ") +
                                        (st.axis_wave_running[a] ? "wave" : "excitation") + on(a) +
                                        ": stop it first (`piezoloop stop`)");
        if (st.axis_tripped[a])
            throw std::invalid_argument("the board's limiter" + on(a) + " is tripped (" +
                                        trip_reason_name(static_cast<TripReason>(st.axis_trip_reason[a])) +
                                        "): clear it first (`piezoloop clear-trip`)" +
                                        (n > 1 ? "; every axis needs its limits group set" : ""));
    }
    if (st.streaming) throw std::invalid_argument("the board is running a setpoint stream: stop it first (`piezoloop stop`)");
    if (closed && c.get<link::FeedbackParams>(axis).kind == FeedbackKind::kNone)
        throw std::invalid_argument("--mode closed: the board has no feedback controller; load one first (`piezoloop set`)");
}

// The column of signal id in a record (its signals are known to be there).
const std::vector<double>& column(const RecordResult& rec, uint8_t id) {
    for (std::size_t k = 0; k < rec.signals.size(); ++k)
        if (rec.signals[k] == id) return rec.values[k];
    throw LinkError("the recording has no signal " + std::string(signal_name(id)));
}

// Runs `measure` with the board prepared. Open loop the controller groups
// are set to none (the loop disarmed first) and put back afterwards, the
// loop left disarmed, whatever happens; closed loop the board's controller
// runs as it is. The recorder group is put back too. An excitation still
// running when something fails is stopped.
template <class F>
void prepared(Client& c, bool closed, uint8_t axis, std::vector<std::string>& warnings, F&& measure) {
    const link::StatusReply st = c.status();
    const link::RecorderParams recorder = c.get<link::RecorderParams>();
    std::optional<ControllerGroups> saved;
    try {
        if (!closed) {
            saved = read_controller(c, axis);
            if (st.armed) {
                c.disarm();
                warnings.push_back("the loop was armed: disarmed for the open-loop measurement");
            }
            write_controller(c, ControllerGroups{}, axis);
        }
        measure();
        if (!closed) c.disarm();
        if (saved) write_controller(c, *saved, axis);
        restore_recorder(c, recorder);
    } catch (...) {
        try {
            c.stop_excitation(axis);
            c.recorder_stop();
            if (!closed) c.disarm();
            if (saved) write_controller(c, *saved, axis);
            restore_recorder(c, recorder);
        } catch (const std::exception&) {
        }
        throw;
    }
}

// One excitation recorded tick by tick (r, y, u, d) from its first sample;
// the recording must be complete.
RecordResult record_excitation(Client& c, const ExcitationConfig& e, uint64_t ticks, bool restart_stage,
                               const MeasureOptions& o) {
    RecordOptions ro;
    ro.signals = {kSignalR, kSignalY, kSignalU, kSignalD};
    ro.duration_s = static_cast<double>(ticks) / static_cast<double>(c.info().loop_rate_Hz);
    ro.excitation = e;
    ro.axis = o.axis;
    ro.restart_stage = restart_stage;
    ro.stop_requested = o.stop_requested;
    ro.progress = o.progress;
    RecordResult rec = record(c, ro);
    if (!rec.complete()) throw LinkError("the recording is incomplete:" + rec.problems());
    return rec;
}

}  // namespace

measure::FrfPlan plan_frf_device(Client& c, const measure::FrfRequest& r, uint8_t axis) {
    const link::HelloReply& h = c.info();
    if ((h.capabilities & link::cap::kExcitation) == 0 || h.excitation_capacity == 0)
        throw std::invalid_argument("this board's firmware has no excitation: update it");
    if (h.recorder_channels < 4)
        throw std::invalid_argument("this board records " + std::to_string(h.recorder_channels) +
                                    " channels; a measurement records r, y, u and d");
    check_axis(c, axis);
    const LimitsConfig limits = c.get<link::LimitsParams>(axis).limits;
    return measure::plan_frf(h.loop_rate_Hz, limits, h.excitation_capacity, r, "board's");
}

DeviceFrfRun run_frf_device(Client& c, const measure::FrfRequest& r, const MeasureOptions& o) {
    const measure::FrfPlan plan = plan_frf_device(c, r, o.axis);
    check_ready(c, r.closed, c.status(), o.axis);
    DeviceFrfRun out;
    out.run.plan = plan;
    link::StatusReply st;
    const auto t0 = std::chrono::steady_clock::now();
    prepared(c, r.closed, o.axis, out.run.warnings, [&] {
        out.record = record_excitation(c, measure::excitation_config(plan, r), plan.ticks, o.restart_stage, o);
        st = c.status();
    });
    out.run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const RecordResult& rec = out.record;
    out.run.log_hash = rec.log_hash.value_or(0);
    // The board counts over the whole excitation, the transient periods included.
    out.run.clipped_samples = st.axis_excitation_clipped[o.axis];
    out.run.clipped_transient = 0;
    out.run.trip = trip_reason_name(static_cast<TripReason>(st.axis_trip_reason[o.axis]));
    const auto first = static_cast<std::ptrdiff_t>(plan.measured_start);
    const auto last = static_cast<std::ptrdiff_t>(plan.ticks);
    auto measured = [&](uint8_t id) {
        const std::vector<double>& v = column(rec, id);
        return std::vector<double>(v.begin() + first, v.begin() + last);
    };
    measure::analyse_frf(r, measured(kSignalU), measured(kSignalY), measured(kSignalD), out.run);
    return out;
}

nlohmann::json recording_summary(const RecordResult& rec) {
    const nlohmann::json summary = summary_json(rec);
    nlohmann::json out;
    for (const char* k : {"frames", "lost_blocks", "recorder_overruns", "tick_overruns", "host_link_dropped"})
        out[k] = summary[k];
    return out;
}

measure::MeasureBounds board_bounds(Client& c, uint8_t axis) {
    const link::HelloReply& h = c.info();
    if ((h.capabilities & link::cap::kExcitation) == 0)
        throw std::invalid_argument("this board's firmware has no excitation: update it");
    check_axis(c, axis);
    measure::MeasureBounds b;
    b.rate_Hz = h.loop_rate_Hz;
    b.limits = c.get<link::LimitsParams>(axis).limits;
    const double fs = h.axis_count > 1 ? h.axis_position_full_scale_um[axis] : h.position_full_scale_um;
    b.closed_range = {-fs, fs};
    b.whose = "board's";
    return b;
}

measure::StepRun run_step_device(Client& c, const measure::StepRequest& r, const MeasureOptions& o) {
    measure::StepRun out;
    out.plan = measure::plan_step(board_bounds(c, o.axis), r);
    const link::StatusReply before = c.status();
    check_ready(c, r.closed, before, o.axis);
    const double rate_Hz = c.info().loop_rate_Hz;
    // Closed loop d adds to the setpoint the board holds.
    const ExcitationConfig e = measure::step_excitation(out.plan, r, rate_Hz, before.axis_r_um[o.axis]);
    RecordResult rec;
    link::StatusReply st;
    const auto t0 = std::chrono::steady_clock::now();
    prepared(c, r.closed, o.axis, out.warnings, [&] {
        rec = record_excitation(c, e, out.plan.hold_ticks + out.plan.post_ticks, o.restart_stage, o);
        st = c.status();
    });
    out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out.log_hash = rec.log_hash.value_or(0);
    out.clipped_samples = st.axis_excitation_clipped[o.axis];
    out.trip = trip_reason_name(static_cast<TripReason>(st.axis_trip_reason[o.axis]));
    measure::analyse_step_run(column(rec, kSignalR), column(rec, kSignalY), column(rec, kSignalU), rate_Hz, out);
    return out;
}

measure::LoopsRun run_loops_device(Client& c, const measure::LoopsRequest& r, const MeasureOptions& o) {
    measure::LoopsRun out;
    out.plan = measure::plan_loops(board_bounds(c, o.axis), r);
    check_ready(c, false, c.status(), o.axis);
    const double rate_Hz = c.info().loop_rate_Hz;
    std::vector<std::vector<double>> u, y;
    const auto t0 = std::chrono::steady_clock::now();
    prepared(c, false, o.axis, out.warnings, [&] {
        for (std::size_t j = 0; j < r.amplitudes_V.size(); ++j) {
            // One recording per amplitude, each from its excitation's first
            // tick; the loop stays armed in between (at u = 0 V until the next
            // starts, so a base other than 0 V sees a short return to 0 V,
            // absorbed by the first of the cycles).
            MeasureOptions oj = o;
            const double n = static_cast<double>(r.amplitudes_V.size());
            if (o.progress) oj.progress = [&, j, n](double f) { o.progress((static_cast<double>(j) + f) / n); };
            const RecordResult rec = record_excitation(c, measure::loop_excitation(out.plan, r, j, rate_Hz),
                                                       out.plan.amplitude_ticks, o.restart_stage && j == 0, oj);
            out.clipped_samples += c.status().axis_excitation_clipped[o.axis];
            u.push_back(column(rec, kSignalU));
            y.push_back(column(rec, kSignalY));
        }
        out.trip = trip_reason_name(static_cast<TripReason>(c.status().axis_trip_reason[o.axis]));
    });
    out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    measure::analyse_loops_run(r, rate_Hz, u, y, out);
    return out;
}

}  // namespace piezoloop::hostlink
