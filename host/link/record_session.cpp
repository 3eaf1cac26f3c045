#include "link/record_session.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "format/number.hpp"
#include "link/csv_log.hpp"
#include "link/params_json.hpp"
#include "piezoloop/approach.hpp"
#include "piezoloop/params/groups.hpp"
#include "piezoloop/reference_run.hpp"
#include "sim/window_metrics.hpp"
#include "link/recorded_signals.hpp"

namespace piezoloop::hostlink {

namespace {

bool has(const std::vector<uint8_t>& ids, uint8_t id) { return std::find(ids.begin(), ids.end(), id) != ids.end(); }

// The device records exactly recorder_channels channels: the requested ones
// first, then others to fill (not written out).
uint8_t signal_axis(const RecordOptions& o, std::size_t k) { return o.signal_axes.empty() ? o.axis : o.signal_axes[k]; }

// The log's channel id of the k-th requested signal: axis * kSignalCount + signal.
uint8_t channel_id(const RecordOptions& o, std::size_t k) {
    return static_cast<uint8_t>(signal_axis(o, k) * kSignalCount + o.signals[k]);
}

link::RecorderParams recorder_params(const RecordOptions& o, const link::HelloReply& h) {
    link::RecorderParams rec;
    rec.channel_count = h.recorder_channels;
    std::vector<uint8_t> ids;  // channel ids
    for (std::size_t k = 0; k < o.signals.size(); ++k) ids.push_back(channel_id(o, k));
    for (uint8_t s = 0; s < kSignalCount && ids.size() < h.recorder_channels; ++s) {
        const auto id = static_cast<uint8_t>(o.axis * kSignalCount + s);
        if (!has(ids, id)) ids.push_back(id);
    }
    for (std::size_t i = 0; i < ids.size(); ++i) {
        rec.channels[i] = ids[i] % kSignalCount;
        rec.axes[i] = ids[i] / kSignalCount;
    }
    rec.trigger_axis = o.axis;
    rec.decimation = o.decimation;
    rec.mode = RecordMode::kContinuous;
    rec.trigger = TriggerMode::kImmediate;
    return rec;
}

// The ticks a wave started now spends approaching its first point, as the
// board computes them in its sample type (Pipeline::approach_ticks): from
// the restarted stage's 0, else from the held setpoint of a loop that stays
// armed (status r), else from the stage's reading (status y). Exact after a
// restart; otherwise the reading may move by its noise before the wave's
// first tick (a tick more or less).
template <class T>
uint64_t approach_ticks_as(const link::HelloReply& h, const link::TrajectoryParams& w, float from_um) {
    const SignalScale pos{h.position_full_scale_um};
    TrajectoryGenerator<T> gen(pos);
    if (!gen.configure(params::trajectory_config(w, h.loop_rate_Hz)).ok()) return 0;
    const uint32_t n = Approach<T>(pos, h.loop_rate_Hz).ticks_for(pos.to_sample<T>(from_um), gen.start_value());
    return n <= 1 ? 0 : n - 1;
}
uint64_t approach_ticks(const link::HelloReply& h, const link::StatusReply& st, const link::TrajectoryParams& w,
                        bool restart, uint8_t axis) {
    const std::size_t a = axis < link::kMaxLinkAxes ? axis : 0;
    const float from_um = restart ? 0.0f : (st.armed ? st.axis_r_um[a] : st.axis_y_um[a]);
    return h.sample_format == link::SampleFormat::kQ31 ? approach_ticks_as<Q31>(h, w, from_um)
                                                       : approach_ticks_as<float>(h, w, from_um);
}

// Collects log blocks until the last wanted tick arrives, the log stalls,
// the caller asks to stop or the link fails.
void collect(Client& c, const RecordOptions& o, uint64_t last_tick, RecordResult& r) {
    auto last_progress = std::chrono::steady_clock::now();
    std::size_t last_size = 0;
    try {
        for (;;) {
            if (o.stop_requested && o.stop_requested()) {
                r.interrupted = true;
                break;
            }
            c.pump(std::chrono::milliseconds(20));
            const std::size_t n = c.log().size();
            if (n > 0 && c.log().tick(n - 1) >= last_tick) break;
            if (n != last_size) {
                last_size = n;
                last_progress = std::chrono::steady_clock::now();
            } else if (std::chrono::duration<double>(std::chrono::steady_clock::now() - last_progress).count() >
                       o.stall_s) {
                r.stalled = true;
                break;
            }
            if (o.progress)
                o.progress(n > 0 ? static_cast<double>(c.log().tick(n - 1)) / static_cast<double>(last_tick + 1) : 0.0);
        }
    } catch (const LinkError& e) {
        r.link_error = e.what();
    }
    if (o.progress) o.progress(1.0);
}

// Stops the recorder and reads what is still on its way; a board that is
// gone or frozen ends this quietly (the record says why it is short).
void stop_recorder(Client& c, RecordResult& r) {
    if (!r.link_error.empty()) return;
    try {
        c.recorder_stop();
        c.pump(std::chrono::milliseconds(50));
        r.tick_overruns = c.status().tick.overruns;
    } catch (const LinkError& e) {
        if (!r.stalled) r.link_error = e.what();
    }
}

void compute_figures(const std::vector<uint8_t>& ids, RecordResult& r) {
    const auto col = [&](uint8_t id) { return static_cast<std::size_t>(std::find(ids.begin(), ids.end(), id) - ids.begin()); };
    if (!(has(ids, kSignalR) && has(ids, kSignalY) && r.frames > 1)) return;
    RecordFigures f;
    f.window = "whole record";
    // The steady-state window `piezoloop sim` uses: the last reference period.
    if (r.wave_running && r.wave.frequency_Hz > 0.0f) {
        const double period_frames = r.rate_Hz / r.wave.frequency_Hz / r.decimation;
        const auto p = static_cast<std::size_t>(std::llround(period_frames));
        if (p >= 2 && p <= r.frames) {
            f.window_start = r.frames - p;
            f.window = "last reference period";
        }
    }
    const std::vector<double>& rv = r.values[col(kSignalR)];
    const std::vector<double>& yv = r.values[col(kSignalY)];
    sim::WindowMetrics m(r.wave_running ? r.wave.offset_um : 0.0);
    for (std::size_t i = f.window_start; i < r.frames; ++i) m.add(rv[i], yv[i]);
    const sim::TrackingMetrics t = m.tracking();
    f.window_frames = r.frames - f.window_start;
    f.hysteresis_pct = m.hysteresis_pct();
    f.e_max_pct = t.e_max_pct;
    f.e_rms_pct = t.e_rms_pct;
    f.e_max_um = t.e_max_um;
    f.e_rms_um = t.e_rms_um;
    f.e_pp_um = t.e_pp_um;
    f.range_um = t.range_um;
    r.figures = f;
}

void write_csv(CsvFile& file, const RecordResult& r) {
    if (!r.complete())
        file.comment("incomplete: " + std::to_string(r.frames) + " of " + std::to_string(r.expected_frames) +
                      " frames;" + r.problems());
    std::vector<std::string> names{"t_s"};
    for (std::size_t k = 0; k < r.signals.size(); ++k) {
        const std::string axis = r.signal_axes.empty() ? "" : std::string(1, "xyz"[r.signal_axes[k] % 3]) + "_";
        names.push_back(std::string(signal_name(r.signals[k])) + "_" + axis + signal_unit(r.signals[k]));
    }
    file.header(names);
    std::vector<double> row(r.signals.size() + 1);
    for (std::size_t i = 0; i < r.frames; ++i) {
        row[0] = r.t_s[i];
        for (std::size_t k = 0; k < r.signals.size(); ++k) row[k + 1] = r.values[k][i];
        file.row(row);
    }
    file.commit();
}

}  // namespace

std::vector<uint8_t> parse_signal_list(const std::string& list) {
    std::vector<uint8_t> ids;
    std::string cell;
    std::stringstream ss(list);
    while (std::getline(ss, cell, ',')) {
        cell.erase(0, cell.find_first_not_of(' '));
        cell.erase(cell.find_last_not_of(' ') + 1);
        if (cell.empty()) continue;
        const uint8_t id = parse_signal(cell);
        if (has(ids, id)) throw std::invalid_argument("--signals: " + cell + " twice");
        ids.push_back(id);
    }
    if (ids.empty()) throw std::invalid_argument("--signals: at least one of r, y, e, u, u_ff, u_fb, u_rc");
    return ids;
}

std::string RecordResult::problems() const {
    std::string p;
    if (interrupted) p += " interrupted before the end;";
    if (!link_error.empty()) p += " the link failed (" + link_error + ");";
    if (stalled) p += " log stalled (no frames for " + format::significant(stall_s) + " s);";
    if (frames < expected_frames) p += " " + std::to_string(expected_frames - frames) + " frames missing;";
    if (!log.clean()) p += " blocks lost/out of order/duplicated, tick gaps or recorder overruns;";
    return p;
}

RecordResult record(Client& c, const RecordOptions& o) {
    if (o.signals.empty()) throw std::invalid_argument("--signals: at least one of r, y, e, u, u_ff, u_fb, u_rc");
    if (o.start_wave && o.excitation) throw std::invalid_argument("a record starts a wave or an excitation, not both");
    if (o.restart_stage && !o.start_wave && !o.excitation)
        throw std::invalid_argument("--restart-stage: only with --start-wave");
    const link::HelloReply h = c.info();
    RecordResult r;
    r.device = c.address();
    r.board = h.board.data();
    r.rate_Hz = h.loop_rate_Hz;
    r.signals = o.signals;
    r.signal_axes = o.signal_axes;
    r.decimation = o.decimation;
    r.stall_s = o.stall_s;
    if (o.signals.size() > h.recorder_channels)
        throw std::invalid_argument("--signals: this board records " + std::to_string(h.recorder_channels) + " channels");
    r.expected_frames = static_cast<std::size_t>(std::llround(o.duration_s * r.rate_Hz / o.decimation));
    if (r.expected_frames == 0) throw std::invalid_argument("--duration-s: shorter than one recorded frame");
    // Created before the board is touched: an --out that cannot be written
    // fails here, not after the record.
    std::unique_ptr<CsvFile> file;
    if (!o.out_csv.empty()) file = std::make_unique<CsvFile>(o.out_csv);

    if (o.axis >= h.axis_count)
        throw std::invalid_argument("--axis: this board has " + std::to_string(h.axis_count) + " axes");
    if (!o.signal_axes.empty() && o.signal_axes.size() != o.signals.size())
        throw std::invalid_argument("signal_axes: one axis per signal");
    for (std::size_t k = 0; k < o.signal_axes.size(); ++k) {
        if (o.signal_axes[k] >= h.axis_count)
            throw std::invalid_argument("signal_axes: this board has " + std::to_string(h.axis_count) + " axes");
        for (std::size_t j = 0; j < k; ++j)
            if (channel_id(o, j) == channel_id(o, k)) throw std::invalid_argument("signal_axes: a signal twice");
    }
    if (o.wave) c.set(*o.wave, o.axis);
    c.set(recorder_params(o, h));
    r.wave = c.get<link::TrajectoryParams>(o.axis);
    link::StatusReply st = c.status();
    if (o.excitation) {
        if (o.restart_stage && st.armed) {
            c.disarm();
            r.notes.push_back("disarmed to restart the loop from rest with the excitation");
            st.armed = false;
        }
        uint8_t flags = wave_flag::kArmRecorder;
        if (!st.armed) flags |= wave_flag::kArm;
        if (o.restart_stage) flags |= wave_flag::kRestartStage;
        c.start_excitation(*o.excitation, flags, o.axis);
    } else if (o.start_wave) {
        if (o.every_axis && h.axis_count < 2)
            throw std::invalid_argument("--every-axis: this board has one axis");
        for (uint8_t a = 0; a < h.axis_count; ++a)
            if ((a == o.axis || o.every_axis) && st.axis_wave_running[a]) c.stop_wave(a);
        if (o.restart_stage && st.armed) {
            c.disarm();
            r.notes.push_back("disarmed to restart the loop from rest with the wave");
            st.armed = false;
        }
        uint8_t flags = wave_flag::kArmRecorder;
        if (!st.armed) flags |= wave_flag::kArm;
        if (o.restart_stage) flags |= wave_flag::kRestartStage;
        r.approach_ticks = approach_ticks(h, st, r.wave, o.restart_stage, o.axis);
        r.expected_frames = static_cast<std::size_t>(
            std::llround((o.duration_s * r.rate_Hz + static_cast<double>(r.approach_ticks)) / o.decimation));
        c.start_wave(flags, o.every_axis ? link::StartWave::kEveryAxis : o.axis);
    } else {
        c.recorder_arm();
    }
    r.wave_running = o.start_wave || st.axis_wave_running[o.axis];

    const uint64_t last_tick = (r.expected_frames - 1) * o.decimation;
    collect(c, o, last_tick, r);
    stop_recorder(c, r);
    c.log().finish();
    const LogCollector& log = c.log();
    r.log = log.stats();
    r.client = c.counters();
    r.host_link_dropped = c.link_counters().dropped();

    // Frames within the requested duration, in physical units.
    while (r.frames < log.size() && log.tick(r.frames) <= last_tick) ++r.frames;
    std::vector<int> cols;
    for (std::size_t j = 0; j < o.signals.size(); ++j) {
        int k = -1;
        for (std::size_t i = 0; i < log.channel_count(); ++i)
            if (log.channels()[i] == channel_id(o, j)) k = static_cast<int>(i);
        if (r.frames > 0 && k < 0)
            throw LinkError("the log blocks do not carry signal " + std::string(signal_name(o.signals[j])));
        cols.push_back(k);
    }
    r.t_s.resize(r.frames);
    r.values.assign(o.signals.size(), std::vector<double>(r.frames));
    for (std::size_t i = 0; i < r.frames; ++i) {
        r.t_s[i] = static_cast<double>(log.tick(i)) / r.rate_Hz;
        for (std::size_t k = 0; k < o.signals.size(); ++k)
            r.values[k][i] = log_sample_physical(log.raw(i)[cols[k]], channel_id(o, k), log.format(), h);
    }
    // log_hash: the fold of `piezoloop sim --hash` (r, y, u bit patterns of
    // each frame, in the board's sample type) over the recorded frames.
    const bool one_axis = std::all_of(o.signal_axes.begin(), o.signal_axes.end(), [&](uint8_t a) { return a == o.axis; });
    if (one_axis && has(o.signals, kSignalR) && has(o.signals, kSignalY) && has(o.signals, kSignalU) && r.frames > 0) {
        const auto col = [&](uint8_t id) { return cols[std::find(o.signals.begin(), o.signals.end(), id) - o.signals.begin()]; };
        reference::LogHash hash;
        const int kr = col(kSignalR), ky = col(kSignalY), ku = col(kSignalU);
        for (std::size_t i = 0; i < r.frames; ++i) {
            hash.add(log.raw(i)[kr]);
            hash.add(log.raw(i)[ky]);
            hash.add(log.raw(i)[ku]);
        }
        r.log_hash = hash.value();
    }
    if (one_axis) compute_figures(o.signals, r);
    if (file) write_csv(*file, r);
    return r;
}

nlohmann::json summary_json(const RecordResult& r) {
    using nlohmann::json;
    std::vector<std::string> names;
    for (const uint8_t id : r.signals) names.emplace_back(signal_name(id));
    json out = {{"device", r.device},
                {"board", r.board},
                {"loop_rate_Hz", r.rate_Hz},
                {"signals", names},
                {"decimation", r.decimation},
                {"frames", r.frames},
                {"expected_frames", r.expected_frames},
                {"approach_ticks", r.approach_ticks},
                {"blocks", r.log.blocks},
                {"lost_blocks", r.log.lost_blocks},
                {"out_of_order", r.log.out_of_order},
                {"duplicates", r.log.duplicates},
                {"tick_gaps", r.log.tick_gaps},
                {"missing_frames", r.log.missing_frames},
                {"recorder_overruns", r.log.recorder_overruns},
                {"inconsistent_blocks", r.log.inconsistent},
                {"stale_replies", r.client.stale_replies},
                {"bad_frames", r.client.bad_replies},
                {"host_link_dropped", r.host_link_dropped},
                {"tick_overruns", r.tick_overruns ? json(*r.tick_overruns) : json()},
                {"stalled", r.stalled},
                {"interrupted", r.interrupted},
                {"complete", r.complete()}};
    if (!r.complete()) out["incomplete"] = r.problems().substr(1);
    if (!r.link_error.empty()) out["link_error"] = r.link_error;
    if (!r.notes.empty()) out["notes"] = r.notes;
    if (r.log_hash) out["log_hash"] = format::hex64(*r.log_hash);
    if (r.figures) {
        const RecordFigures& f = *r.figures;
        out["window"] = f.window;
        out["window_frames"] = f.window_frames;
        out["hysteresis_pct"] = f.hysteresis_pct >= 0.0 ? json(f.hysteresis_pct) : json();
        out["e_max_pct"] = f.e_max_pct;
        out["e_rms_pct"] = f.e_rms_pct;
        out["e_max_um"] = f.e_max_um;
        out["e_rms_um"] = f.e_rms_um;
        out["e_pp_um"] = f.e_pp_um;
        out["range_um"] = f.range_um;
    }
    return out;
}

nlohmann::json plot_spec(const RecordResult& r, const std::string& png) {
    const auto col = [&](uint8_t id) -> const std::vector<double>* {
        const auto it = std::find(r.signals.begin(), r.signals.end(), id);
        return it == r.signals.end() ? nullptr : &r.values[static_cast<std::size_t>(it - r.signals.begin())];
    };
    if (r.frames == 0 || !col(kSignalR) || !col(kSignalY) || !col(kSignalU)) return {};
    nlohmann::json spec;
    spec["kind"] = "sim";
    spec["output"] = png;
    std::string title = r.board + " (" + r.device + "): record";
    if (r.wave_running)
        title += ", " + std::string(waveform_name(r.wave.waveform)) + " " + format::significant(r.wave.frequency_Hz) +
                 " Hz, " + format::significant(2.0 * static_cast<double>(r.wave.amplitude_um)) + " um p-p";
    spec["title"] = title;
    spec["t_s"] = r.t_s;
    spec["r_um"] = *col(kSignalR);
    spec["y_um"] = *col(kSignalY);
    spec["u_V"] = *col(kSignalU);
    const std::size_t window_start = r.figures ? r.figures->window_start : 0;
    spec["window_start_s"] = r.t_s[window_start];
    return spec;
}

}  // namespace piezoloop::hostlink
