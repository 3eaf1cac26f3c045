#include "link/scan_session.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "piezoloop/axes/multi_axis_pipeline.hpp"
#include "piezoloop/link/device_scan.hpp"
#include "piezoloop/scan/scan_generator.hpp"
#include "link/recorded_signals.hpp"

namespace piezoloop::hostlink {
namespace {

using Clock = std::chrono::steady_clock;

float axis_full_scale(const link::HelloReply& h, int axis) {
    return axis == 0 || h.axis_count <= 1 ? h.position_full_scale_um : h.axis_position_full_scale_um[axis];
}

// The recorder's channels: x's and y's readings, the sync word, then x's
// and y's references and commands and z's reading (or x's error) to fill.
link::RecorderParams scan_recorder(const link::HelloReply& h) {
    struct Channel {
        uint8_t signal, axis;
    };
    const uint8_t y = kSignalY, r = kSignalR, u = kSignalU;
    const Channel wanted[] = {{y, 0}, {y, 1}, {params::kSyncChannel, 0}, {r, 0}, {r, 1}, {u, 0}, {u, 1},
                              h.axis_count > 2 ? Channel{y, 2} : Channel{signal_index(SignalId::kE), 0}};
    if (h.recorder_channels < 3 || h.recorder_channels > std::size(wanted))
        throw std::invalid_argument("this board's recorder has " + std::to_string(h.recorder_channels) +
                                    " channels; a scan records 3 to 8");
    link::RecorderParams rec;
    rec.channel_count = h.recorder_channels;
    for (std::size_t i = 0; i < h.recorder_channels; ++i) {
        rec.channels[i] = wanted[i].signal;
        rec.axes[i] = wanted[i].axis;
    }
    rec.decimation = 1;
    rec.mode = RecordMode::kContinuous;
    rec.trigger = TriggerMode::kImmediate;
    return rec;
}

uint32_t sync_of(uint32_t raw, link::SampleFormat f) {
    if (f == link::SampleFormat::kQ31) return raw;
    const float v = std::bit_cast<float>(raw);
    return v >= 0.0f && v < 4294967296.0f ? static_cast<uint32_t>(v) : 0xFFFFFFFFu;
}

// The scan's path as the board's generator computes it, in its sample type,
// one row per recorded tick from the approach's end.
template <class T>
void fill_ticks(Client& c, const ScanConfig& cfg, const DeviceScanOptions& o, uint32_t approach_ticks,
                uint64_t end_tick, DeviceScanResult& out) {
    const link::HelloReply& h = c.info();
    const SignalScale sx{axis_full_scale(h, 0)}, sy{axis_full_scale(h, 1)},
        sz{axis_full_scale(h, h.axis_count > 2 ? 2 : 0)};
    ScanGenerator<T> g(sx, sy, sz);
    if (!g.configure(cfg).ok()) return;  // the board accepted it: cannot happen
    const LogCollector& log = c.log();
    const link::SampleFormat f = log.format();
    const auto& ids = log.channels();
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (std::size_t i = 0; i < log.size(); ++i) {
        const uint64_t k = log.tick(i);
        if (k != i) {
            out.problems += " frames missing from tick " + std::to_string(i) + ";";
            break;
        }
        if (k >= end_tick) break;
        if (k < approach_ticks) continue;
        const ScanPoint<T> p = g.step();
        const uint32_t* raw = log.raw(i);
        scan::ScanTick t;
        t.commanded_x_um = sx.to_physical(p.x);
        t.commanded_y_um = sy.to_physical(p.y);
        t.measured_x_um = log_sample_physical(raw[0], ids[0], f, h);
        t.measured_y_um = log_sample_physical(raw[1], ids[1], f, h);
        t.true_x_um = t.true_y_um = nan;
        t.height_nm = o.sample.height_at_nm(t.measured_x_um, t.measured_y_um);
        t.sync = sync_of(raw[2], f);
        if (t.sync != p.sync) ++out.sync_mismatches;
        out.run.ticks.push_back(t);
    }
}

}  // namespace

DeviceScanResult run_scan_device(Client& c, const DeviceScanOptions& o) {
    const link::HelloReply& h = c.info();
    if ((h.capabilities & link::cap::kScan) == 0)
        throw std::invalid_argument("this board runs no scans: a scan needs a board of two or three axes (hello "
                                    "axis_count " + std::to_string(h.axis_count) + ")");
    const link::StatusReply before = c.status();
    for (int a = 0; a < before.axis_count && a < static_cast<int>(link::kMaxLinkAxes); ++a)
        if (before.axis_tripped[a])
            throw std::invalid_argument(std::string("the board's axis ") + "xyz"[a] +
                                        " is tripped: clear the trip first (piezoloop clear-trip)");
    ScanConfig cfg = o.scan;
    cfg.sample_rate_Hz = h.loop_rate_Hz;
    if (h.axis_count > 2) {
        // z is held where it is (the restarted stage's 0).
        cfg.hold_z_um = o.restart_stage ? 0.0f : (before.armed ? before.axis_r_um[2] : before.axis_y_um[2]);
    }
    ScanGenerator<float> plan;
    if (const Status s = plan.configure(cfg); !s.ok()) throw std::invalid_argument(describe(s));
    const uint64_t scan_ticks = uint64_t{plan.frame_period_ticks()} * (cfg.frames == 0 ? 1u : cfg.frames);

    // x's and y's repetitive controllers learn over the scan's fast motion.
    DeviceScanResult out;
    for (uint8_t a = 0; a < 2; ++a) {
        const uint32_t period = scan::scan_rc_period_ticks(cfg, a);
        link::RepetitiveParams rc = c.get<link::RepetitiveParams>(a);
        if (!rc.enabled || rc.rc.period_samples == static_cast<int>(period)) continue;
        const std::string axis(1, "xy"[a]);
        if (o.rc_period_from_scan) {
            const int was = rc.rc.period_samples;
            rc.rc.period_samples = static_cast<int>(period);
            c.set(rc, a);
            out.notes.push_back(axis + "'s repetitive controller: period " + std::to_string(was) + " -> " +
                                std::to_string(period) + " ticks, the scan's");
        } else {
            out.notes.push_back(axis + "'s repetitive controller runs a period of " +
                                std::to_string(rc.rc.period_samples) + " ticks, the scan's fast motion " +
                                std::to_string(period) + ": it learns over the wrong period (set rc.period_samples, "
                                "or let the scan set it: --rc-period-from-scan, rc_period_from_scan=True)");
        }
    }
    c.set(scan_recorder(h));
    const uint8_t flags = wave_flag::kArmRecorder | (before.armed ? 0 : wave_flag::kArm) |
                          (o.restart_stage ? wave_flag::kRestartStage : 0);
    c.start_scan(cfg, flags);

    bool ended = false, interrupted = false, stalled = false;
    link::StatusReply st{};
    std::string link_error;
    auto last_status = Clock::now() - std::chrono::seconds(1);
    auto last_progress = Clock::now();
    std::size_t last_size = 0;
    try {
        for (;;) {
            if (!interrupted && o.stop_requested && o.stop_requested()) {
                c.stop_waves();  // stops the scan where it is
                interrupted = true;
            }
            c.pump(std::chrono::milliseconds(20));
            const std::size_t n = c.log().size();
            if (Clock::now() - last_status > std::chrono::milliseconds(200)) {
                st = c.status();
                last_status = Clock::now();
                ended = st.scan_state == static_cast<uint8_t>(link::ScanState::kEnded);
                if (o.progress) o.progress(n, st.scan_approach_ticks + scan_ticks);
            }
            if (ended && n > 0 && c.log().tick(n - 1) + 1 >= st.scan_ticks) break;
            if (n != last_size) {
                last_size = n;
                last_progress = Clock::now();
            } else if (std::chrono::duration<double>(Clock::now() - last_progress).count() > o.stall_s) {
                stalled = true;
                break;
            }
        }
        c.recorder_stop();
        c.pump(std::chrono::milliseconds(50));
        st = c.status();
    } catch (const LinkError& e) {
        link_error = e.what();
    }
    c.log().finish();
    out.run.q31 = h.sample_format == link::SampleFormat::kQ31;
    out.run.approach_ticks = st.scan_approach_ticks;
    out.run.frames_completed = st.scan_frames_completed;
    const uint64_t end_tick = ended ? st.scan_ticks : std::numeric_limits<uint64_t>::max();
    if (out.run.q31) fill_ticks<Q31>(c, cfg, o, st.scan_approach_ticks, end_tick, out);
    else fill_ticks<float>(c, cfg, o, st.scan_approach_ticks, end_tick, out);
    if (interrupted) out.problems += " stopped before the end (Ctrl-C or SIGTERM);";
    if (stalled) out.problems += " the log stalled (no frames for " + std::to_string(o.stall_s) + " s);";
    if (!link_error.empty()) out.problems += " the link failed (" + link_error + ");";
    if (!c.log().stats().clean()) out.problems += " blocks lost, out of order or recorder overruns;";
    if (ended && !interrupted && cfg.frames != 0 && st.scan_frames_completed < cfg.frames)
        out.problems += " the board ended the scan after " + std::to_string(st.scan_frames_completed) + " frames;";
    out.run.complete = out.problems.empty() && ended;
    if (o.progress) o.progress(1, 1);
    return out;
}

scan::ScanPlan plan_board_scan(Client& c, const scan::ScanRequest& r, const sim::Scenario* stage,
                               const scan::FieldName& name, std::string* label_out) {
    const link::HelloReply& h = c.info();
    scan::ScanBounds b;
    std::string label = h.board.data();
    if (stage != nullptr) {
        if (stage->axes.size() < 2)
            throw std::invalid_argument(name("scenario") + ": a scan needs a stage of two or three axes (plant.axes)");
        if (stage->setup.rate_Hz != h.loop_rate_Hz)
            throw std::invalid_argument(name("scenario") + ": its loop rate (" + std::to_string(stage->setup.rate_Hz) +
                                        " Hz) is not the board's (" + std::to_string(h.loop_rate_Hz) + " Hz)");
        b = scan::scenario_bounds(*stage);
        label = stage->name + " on " + label;
    } else {
        if (!r.centre_um)
            throw std::invalid_argument(name("centre_um") +
                                        ": needed on a board without a scenario (the stage's travel is not known)");
        const double fx = axis_full_scale(h, 0), fy = axis_full_scale(h, 1);
        b.travel_x_um = {-fx, fx};
        b.travel_y_um = {-fy, fy};
        b.whose = "board's position range";
    }
    b.rate_Hz = h.loop_rate_Hz;
    b.position = SignalScale{h.position_full_scale_um};
    if (label_out != nullptr) *label_out = label;
    return scan::plan_scan(b, r, name);
}

BoardScan scan_on_board(Client& c, const scan::ScanRequest& r, const sim::Scenario* stage, const scan::FieldName& name,
                        const BoardScanOptions& bo) {
    BoardScan d;
    std::string label;
    d.plan = plan_board_scan(c, r, stage, name, &label);
    d.rate_Hz = c.info().loop_rate_Hz;
    DeviceScanOptions o;
    o.scan = d.plan.config;
    o.sample = d.plan.sample;
    o.restart_stage = bo.restart_stage;
    o.rc_period_from_scan = bo.rc_period_from_scan;
    o.stop_requested = bo.stop_requested;
    o.progress = bo.progress;
    const auto t0 = Clock::now();
    DeviceScanResult res = run_scan_device(c, o);
    d.outcome.run = std::move(res.run);
    d.outcome.simulate_wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
    scan::analyse_scan(d.plan, d.rate_Hz, label, d.outcome);
    d.outcome.figures["device"] = c.address();
    d.outcome.figures["sync_mismatches"] = res.sync_mismatches;
    d.outcome.figures["probe"] = "at the measured positions (a board streams no true position)";
    if (!res.notes.empty()) d.outcome.figures["rc"] = res.notes;
    d.problems = res.problems;
    if (!d.problems.empty()) d.outcome.figures["incomplete"] = d.problems;
    return d;
}

}  // namespace piezoloop::hostlink
