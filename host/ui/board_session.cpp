#include "ui/board_session.hpp"

#include "link/recorded_signals.hpp"

#include <algorithm>
#include <chrono>
#include <limits>

#include "device_common.hpp"
#include "link/params_json.hpp"
#include "piezoloop/params/field_check.hpp"
#include "status_text.hpp"
#include "ui/field_refusal.hpp"
#include "ui/wall_clock.hpp"

namespace piezoloop::ui {

using nlohmann::json;
using namespace std::chrono_literals;

namespace {

// "group.key: ..." of params_json's merge errors: the key.
std::string field_of_message(const std::string& group, const std::string& message) {
    const std::string prefix = group + ".";
    if (message.rfind(prefix, 0) != 0) return "";
    const auto end = message.find_first_of(":[. ", prefix.size());
    return message.substr(prefix.size(), end == std::string::npos ? std::string::npos : end - prefix.size());
}

template <class G>
json read_group(hostlink::Client& c, uint8_t axis = 0) {
    return hostlink::to_json(c.get<G>(link::board_group(G::kGroup) ? 0 : axis));
}

// The console recorder's channel ids (axis * kSignalCount + signal): one
// axis, its first recorder_channels signals (r, y, e, u); a board of axes,
// x's r and y, then each other axis's y and r while there is room (eight
// channels: r and y of every axis, then x's e and u).
std::vector<uint8_t> console_channels(const link::HelloReply& h) {
    std::vector<uint8_t> ids;
    if (h.axis_count <= 1) {
        for (uint8_t i = 0; i < h.recorder_channels; ++i) ids.push_back(i);
        return ids;
    }
    ids = {hostlink::kSignalR, hostlink::kSignalY};
    for (uint8_t a = 1; a < h.axis_count && ids.size() < h.recorder_channels; ++a)
        ids.push_back(static_cast<uint8_t>(a * kSignalCount + hostlink::kSignalY));
    for (uint8_t a = 1; a < h.axis_count && ids.size() < h.recorder_channels; ++a)
        ids.push_back(static_cast<uint8_t>(a * kSignalCount + hostlink::kSignalR));
    for (uint8_t s = 0; s < kSignalCount && ids.size() < h.recorder_channels; ++s)
        if (std::find(ids.begin(), ids.end(), s) == ids.end()) ids.push_back(s);
    return ids;
}

// A channel's name in the console: axis 0's signals by their own name (r,
// y, ...), another axis's with the axis before it (y.y, z.y).
std::string channel_name(uint8_t id) {
    const std::string signal = hostlink::signal_name(static_cast<uint8_t>(id % kSignalCount));
    return id < kSignalCount ? signal : std::string(1, "xyz"[(id / kSignalCount) % 3]) + "." + signal;
}

}  // namespace

json SetOutcome::to_json() const {
    json j = {{"ok", ok}, {"values", values}};
    if (!ok)
        j["error"] = {{"refused_by", refused_by}, {"group", group}, {"field", field}, {"index", index},
                      {"message", message}};
    return j;
}

const std::vector<std::string>& BoardSession::form_groups() {
    static const std::vector<std::string> g = {"limits", "feedforward", "feedback", "rc", "trajectory", "link"};
    return g;
}

BoardSession::BoardSession(hostlink::Client client, double history_s) : client_(std::move(client)) {
    address_ = client_.address();
    hello_ = client_.info();
    channels_ = console_channels(hello_);
    std::vector<Signal> signals;
    for (const uint8_t id : channels_) signals.push_back({channel_name(id), hostlink::signal_unit(id)});
    const auto capacity = static_cast<std::size_t>(history_s * hello_.loop_rate_Hz);
    history_ = std::make_unique<SampleHistory>(std::move(signals), hello_.loop_rate_Hz, capacity);
}

BoardSession::~BoardSession() { stop(); }

std::vector<std::string> BoardSession::channel_choices() const {
    std::vector<std::string> names;
    const std::size_t axes = std::max<std::size_t>(hello_.axis_count, 1);
    for (std::size_t id = 0; id < axes * kSignalCount; ++id) names.push_back(channel_name(static_cast<uint8_t>(id)));
    return names;
}

void BoardSession::set_scope_channels(const std::vector<std::string>& names) {
    const std::vector<std::string> choices = channel_choices();
    if (names.empty() || names.size() > hello_.recorder_channels)
        throw std::invalid_argument("channels: 1 to " + std::to_string(hello_.recorder_channels) +
                                    " of the board's recorder channels, got " + std::to_string(names.size()));
    std::vector<uint8_t> ids;
    std::vector<Signal> signals;
    for (const std::string& n : names) {
        const auto at = std::find(choices.begin(), choices.end(), n);
        if (at == choices.end()) {
            std::string all;
            for (const std::string& c : choices) all += (all.empty() ? "" : ", ") + c;
            throw std::invalid_argument("channels: '" + n + "' is no channel of this board (" + all + ")");
        }
        const auto id = static_cast<uint8_t>(at - choices.begin());
        if (std::find(ids.begin(), ids.end(), id) != ids.end())
            throw std::invalid_argument("channels: '" + n + "' given twice");
        ids.push_back(id);
        signals.push_back({n, hostlink::signal_unit(id)});
    }
    locked([&](hostlink::Client&) {
        const std::vector<uint8_t> before = channels_;
        channels_ = ids;
        try {
            arm_console_recorder();  // a new recording: the host's log starts again
        } catch (...) {
            channels_ = before;  // the board refused: the channels as they were
            arm_console_recorder();
            throw;
        }
        history_->reset(std::move(signals));
        have_last_ = false;
        return 0;
    });
}

void BoardSession::start() {
    locked([&](hostlink::Client& c) {
        arm_console_recorder();
        limits_ = read_group<link::LimitsParams>(c);
        return 0;
    });
    poll_status();
    running_ = true;
    thread_ = std::thread([this] { run(); });
}

void BoardSession::arm_console_recorder() {
    link::RecorderParams rec;
    rec.channel_count = hello_.recorder_channels;
    // The board records exactly recorder_channels channels: the console's,
    // then axis 0's others to fill.
    std::vector<uint8_t> ids = channels_;
    for (uint8_t s = 0; s < kSignalCount && ids.size() < hello_.recorder_channels; ++s)
        if (std::find(ids.begin(), ids.end(), s) == ids.end()) ids.push_back(s);
    for (std::size_t i = 0; i < ids.size(); ++i) {
        rec.channels[i] = ids[i] % kSignalCount;
        rec.axes[i] = ids[i] / kSignalCount;
    }
    rec.decimation = 1;
    rec.mode = RecordMode::kContinuous;
    rec.trigger = TriggerMode::kImmediate;
    client_.set(rec);
    client_.recorder_arm();  // clears the host's log: a new recording
    new_recording_ = true;
}

void BoardSession::stop() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
    try {
        locked([](hostlink::Client& c) {
            c.recorder_stop();
            return 0;
        });
    } catch (const std::exception&) {
        // The board is gone: nothing to stop.
    }
}

void BoardSession::run() {
    auto next_status = std::chrono::steady_clock::now();
    while (running_) {
        if (measuring_) {  // the measurement reads the link and polls the status
            std::this_thread::sleep_for(20ms);
            continue;
        }
        try {
            locked([&](hostlink::Client& c) {
                c.pump(4ms);
                return 0;
            });
            take_log_frames();
            if (std::chrono::steady_clock::now() >= next_status) {
                poll_status();
                next_status = std::chrono::steady_clock::now() + 200ms;
            }
        } catch (const BoardBusy&) {
            continue;
        } catch (const std::exception& e) {
            const std::lock_guard lock(status_m_);
            link_error_ = e.what();
            status_["link_error"] = link_error_;
            ++status_serial_;
            std::this_thread::sleep_for(500ms);
        }
        std::this_thread::sleep_for(1ms);  // lets a waiting request take the link
    }
}

void BoardSession::take_log_frames() {
    if (measuring_) return;
    const std::lock_guard lock(link_);
    const std::size_t n = client_.log().size();
    append_log_frames(0);
    client_.log().drop_front(n);
}

void BoardSession::append_log_frames(std::size_t from) {
    const hostlink::LogCollector& log = client_.log();
    const std::size_t n = log.size();
    if (from >= n) return;
    if (new_recording_) {
        // After the last by the board's tick counter; one that went back (a
        // restarted emulated stage may restart it) or stood: just after.
        uint32_t gap = log.first_tick_raw() - last_raw_;
        if (gap == 0 || gap >= (1u << 31)) gap = 1;
        recording_offset_ = have_last_ ? last_tick_ + gap : 0;
        new_recording_ = false;
    }
    const int64_t arrival = wall_clock_ms();
    const std::size_t channels = log.channel_count();
    std::vector<float> values(history_->signals().size());
    for (std::size_t i = from; i < n; ++i) {
        std::fill(values.begin(), values.end(), std::numeric_limits<float>::quiet_NaN());
        const uint32_t* raw = log.raw(i);
        for (std::size_t ch = 0; ch < channels; ++ch) {
            const uint8_t id = log.channels()[ch];
            const auto at = std::find(channels_.begin(), channels_.end(), id);
            if (at != channels_.end())
                values[static_cast<std::size_t>(at - channels_.begin())] =
                    static_cast<float>(hostlink::log_sample_physical(raw[ch], id, log.format(), hello_));
        }
        history_->append(recording_offset_ + log.tick(i), values, arrival);
    }
    last_tick_ = recording_offset_ + log.tick(n - 1);
    last_raw_ = log.first_tick_raw() + static_cast<uint32_t>(log.tick(n - 1));
    have_last_ = true;
}

measure::FrfPlan BoardSession::plan_frf(const measure::FrfRequest& r, uint8_t axis) {
    return locked([&](hostlink::Client& c) { return hostlink::plan_frf_device(c, r, axis); });
}

hostlink::DeviceFrfRun BoardSession::measure_frf(const measure::FrfRequest& r, hostlink::MeasureOptions o) {
    hostlink::DeviceFrfRun run;
    measure(std::move(o), [&](hostlink::Client& c, const hostlink::MeasureOptions& mo) { run = hostlink::run_frf_device(c, r, mo); });
    return run;
}

measure::MeasureBounds BoardSession::measure_bounds(uint8_t axis) {
    return locked([axis](hostlink::Client& c) { return hostlink::board_bounds(c, axis); });
}

double BoardSession::setpoint_um(uint8_t axis) {
    return locked([axis](hostlink::Client& c) { return static_cast<double>(c.status().axis_r_um[axis]); });
}

measure::StepRun BoardSession::measure_step(const measure::StepRequest& r, hostlink::MeasureOptions o) {
    measure::StepRun run;
    measure(std::move(o), [&](hostlink::Client& c, const hostlink::MeasureOptions& mo) { run = hostlink::run_step_device(c, r, mo); });
    return run;
}

measure::LoopsRun BoardSession::measure_loops(const measure::LoopsRequest& r, hostlink::MeasureOptions o) {
    measure::LoopsRun run;
    measure(std::move(o), [&](hostlink::Client& c, const hostlink::MeasureOptions& mo) { run = hostlink::run_loops_device(c, r, mo); });
    return run;
}

void BoardSession::plan_scan(const scan::ScanRequest& r, const sim::Scenario* stage, const scan::FieldName& name) {
    locked([&](hostlink::Client& c) { (void)hostlink::plan_board_scan(c, r, stage, name); });
}

hostlink::BoardScan BoardSession::scan(const scan::ScanRequest& r, const sim::Scenario* stage,
                                       const scan::FieldName& name, bool restart_stage,
                                       std::function<bool()> stop_requested,
                                       const std::function<void(uint64_t tick, uint64_t total)>& progress) {
    hostlink::BoardScan out;
    hostlink::MeasureOptions o;
    o.stop_requested = std::move(stop_requested);
    o.progress = [progress](double f) {
        if (progress) progress(static_cast<uint64_t>(f * 1e6), 1000000u);
    };
    measure(std::move(o), [&](hostlink::Client& c, const hostlink::MeasureOptions& mo) {
        hostlink::BoardScanOptions so;
        so.restart_stage = restart_stage;
        so.stop_requested = mo.stop_requested;
        so.progress = [&mo](uint64_t k, uint64_t total) {
            mo.progress(total ? std::min(1.0, static_cast<double>(k) / static_cast<double>(total)) : 1.0);
        };
        out = hostlink::scan_on_board(c, r, stage, name, so);
    });
    return out;
}

json BoardSession::commission(cli::CommissionSession s, const std::function<void(const std::string&)>& note,
                              const std::function<bool()>& stop_requested) {
    json out;
    hostlink::MeasureOptions o;
    o.progress = s.recording_progress;
    o.stop_requested = stop_requested;
    measure(std::move(o), [&](hostlink::Client& c, const hostlink::MeasureOptions& mo) {
        s.recording_progress = mo.progress;
        out = cli::run_commission_session(&c, s, note, stop_requested);
    });
    return out;
}

json BoardSession::commission_axes(const cli::AxesCommission& a, bool save,
                                   const std::function<void(const std::string&)>& note,
                                   const std::function<bool()>& stop_requested) {
    json out;
    hostlink::MeasureOptions o;
    o.stop_requested = stop_requested;
    measure(std::move(o), [&](hostlink::Client& c, const hostlink::MeasureOptions&) {
        out = cli::run_axes_commission_board(c, a, save, note, stop_requested);
    });
    return out;
}

void BoardSession::measure(hostlink::MeasureOptions o,
                           const std::function<void(hostlink::Client&, const hostlink::MeasureOptions&)>& body) {
    if (measuring_.exchange(true)) throw BoardBusy("a measurement is running already");
    const std::lock_guard lock(link_);
    // The console's recording up to here; the measurement's frames go into
    // the history as they arrive (its recording is the log's from the
    // excitation's start, which is when its progress is first reported).
    const std::size_t console_frames = client_.log().size();
    append_log_frames(0);
    client_.log().drop_front(console_frames);
    bool started = false;
    std::size_t taken = 0;
    uint32_t first_raw = 0;
    auto last_status = std::chrono::steady_clock::now();
    const std::function<void(double)> report = o.progress;
    o.progress = [&](double f) {
        // A measurement of several recordings (loops: one per amplitude)
        // clears the log for each: a new recording, after the last (the
        // frames of the one before that came after its last report are
        // not in the history).
        const hostlink::LogCollector& log = client_.log();
        if (!started || log.size() < taken || log.first_tick_raw() != first_raw) {
            started = true;
            new_recording_ = true;
            taken = 0;
            first_raw = log.first_tick_raw();
        }
        append_log_frames(taken);
        taken = log.size();
        if (std::chrono::steady_clock::now() - last_status >= 200ms) {
            poll_status_locked();
            last_status = std::chrono::steady_clock::now();
        }
        if (report) report(f);
    };
    // Whatever happened: the rest of the recording into the history, the
    // console's recorder back, the status read.
    auto finish = [&] {
        try {
            if (started && client_.log().size() >= taken && client_.log().first_tick_raw() == first_raw)
                append_log_frames(taken);
            arm_console_recorder();
            measuring_ = false;
            poll_status_locked();
        } catch (const std::exception& e) {
            const std::lock_guard s(status_m_);
            link_error_ = e.what();
            status_["link_error"] = link_error_;
            ++status_serial_;
        }
        measuring_ = false;
    };
    try {
        body(client_, o);
        finish();
    } catch (...) {
        finish();
        throw;
    }
}

void BoardSession::poll_status() {
    if (measuring_) return;  // the measurement polls it
    const std::lock_guard lock(link_);
    poll_status_locked();
}

void BoardSession::poll_status_locked() {
    json j;
    {
        const link::StatusReply st = client_.status();
        last_status_ = st;
        j["status"] = hostlink::to_json(st);
        j["storage_text"] = storage_state_text(st.storage);
        const hostlink::ClientCounters& cc = client_.counters();
        const hostlink::LogStats& ls = client_.log().stats();
        j["host_link"] = {{"requests", cc.requests},       {"stale_replies", cc.stale_replies},
                          {"bad_replies", cc.bad_replies}, {"log_blocks", cc.log_blocks},
                          {"bytes_received", cc.bytes_received}, {"log_frames", ls.frames},
                          {"lost_blocks", ls.lost_blocks}, {"tick_gaps", ls.tick_gaps},
                          {"recorder_overruns", ls.recorder_overruns}};
    }
    json meanings = json::array();
    for (const auto& f : j["status"]["faults"]) {
        meanings.push_back({{"fault", f}, {"meaning", fault_meaning(f.get<std::string>())}});
    }
    j["fault_meanings"] = meanings;
    j["trip_meaning"] = trip_meaning(j["status"]["trip_reason"].get<std::string>());
    if (hello_.axis_count > 1) {
        const link::StatusReply& st = last_status_;
        j["axes"] = json::array();
        for (int a = 0; a < hello_.axis_count; ++a) {
            json ax = hostlink::axis_status_json(st, a);
            ax["trip_meaning"] = trip_meaning(ax["trip_reason"].get<std::string>());
            j["axes"].push_back(ax);
        }
    }
    j["device"] = address_;
    j["measuring"] = measuring_.load();
    j["hello"] = hostlink::to_json(hello_);
    const std::lock_guard lock(status_m_);
    j["limits"] = limits_;
    if (!link_error_.empty()) j["link_error"] = link_error_;
    status_ = std::move(j);
    ++status_serial_;
}

json BoardSession::status_json() const {
    const std::lock_guard lock(status_m_);
    return status_;
}

void BoardSession::arm() {
    locked([](hostlink::Client& c) {
        c.arm();
        return 0;
    });
    poll_status();
}

void BoardSession::disarm() {
    locked([](hostlink::Client& c) {
        c.disarm();
        return 0;
    });
    poll_status();
}

void BoardSession::clear_trip() {
    locked([](hostlink::Client& c) {
        c.clear_trip();
        return 0;
    });
    poll_status();
}

void BoardSession::stop_motion() {
    locked([](hostlink::Client& c) {
        c.stop_waves();
        c.stream_stop(false);
        return 0;
    });
    poll_status();
}

uint8_t BoardSession::axis_index(const std::string& name) const {
    if (name.empty() && hello_.axis_count <= 1) return 0;
    for (int a = 0; a < hello_.axis_count; ++a)
        if (name == std::string(1, "xyz"[a])) return static_cast<uint8_t>(a);
    const std::string names = hello_.axis_count == 2 ? "x, y" : hello_.axis_count == 3 ? "x, y, z" : "x";
    throw std::invalid_argument("axis: " + (name.empty() ? std::string("give one") : "'" + name + "' is none") +
                                " of this board's axes (" + names + ")");
}

uint8_t axis_field(const BoardSession& board, const std::string& name) {
    try {
        return board.axis_index(name);
    } catch (const std::invalid_argument& e) {
        throw FieldRefusal("axis", e.what());
    }
}

json BoardSession::group_json(const std::string& group, uint8_t axis) {
    const link::ParamGroup g = hostlink::parse_group(group);
    json out;
    locked([&](hostlink::Client& c) {
        params::with_group(g, [&](auto tag) { out = read_group<typename decltype(tag)::type>(c, axis); });
        return 0;
    });
    return out;
}

json BoardSession::groups_json(uint8_t axis) {
    json out;
    for (const std::string& g : form_groups()) out[g] = group_json(g, axis);
    return out;
}

SetOutcome BoardSession::set_group(const std::string& group, const json& fields, uint8_t axis) {
    if (std::find(form_groups().begin(), form_groups().end(), group) == form_groups().end())
        throw std::invalid_argument("group: '" + group + "' is not one the console edits");
    const link::ParamGroup g = hostlink::parse_group(group);
    SetOutcome out;
    out.group = group;
    locked([&](hostlink::Client& c) {
        params::with_group(g, [&](auto tag) {
            using G = typename decltype(tag)::type;
            const uint8_t a = link::board_group(G::kGroup) ? 0 : axis;
            G value = c.get<G>(a);
            try {
                hostlink::merge_json(fields, value);
                params::FieldCheck check;
                if (const Status s = check.check(value); !s.ok()) {
                    out.ok = false;
                    out.refused_by = "host";
                    out.field = s.field ? s.field : "";
                    out.index = s.index;
                    out.message = piezoloop::describe(s);
                } else {
                    c.set(value, a);
                }
            } catch (const hostlink::DeviceError& e) {
                out.ok = false;
                out.refused_by = "board";
                out.field = e.field();
                out.index = e.reply().index;
                out.message = hostlink::describe(e.reply());
            } catch (const std::invalid_argument& e) {
                out.ok = false;
                out.refused_by = "host";
                out.field = field_of_message(group, e.what());
                out.message = e.what();
            }
            out.values = read_group<G>(c, a);
        });
        if (g == link::ParamGroup::kLimits && axis == 0) {
            const std::lock_guard lock(status_m_);
            limits_ = out.values;
        }
        return 0;
    });
    poll_status();
    return out;
}

json BoardSession::start_wave(const json& request) {
    cli::WaveRequest w;
    bool arm = false;
    uint8_t axis = 0;
    for (auto it = request.begin(); it != request.end(); ++it) {
        const std::string& k = it.key();
        if (k == "trajectory") w.trajectory = it->get<std::string>();
        else if (k == "frequency_Hz") w.frequency_Hz = it->get<double>();
        else if (k == "amplitude_um") w.amplitude_um = it->get<double>();
        else if (k == "offset") w.offset = it->get<std::string>();
        else if (k == "cycles") w.cycles = it->get<uint32_t>();
        else if (k == "arm") arm = it->get<bool>();
        else if (k == "axis") axis = axis_index(it->get<std::string>());
        else throw std::invalid_argument("wave." + k + ": unknown field (trajectory, frequency_Hz, amplitude_um, "
                                         "offset, cycles, arm, axis)");
    }
    cli::check_wave_request(w);
    json out;
    locked([&](hostlink::Client& c) {
        const link::TrajectoryParams p = cli::wave_params(w, hello_.loop_rate_Hz);
        c.set(p, axis);
        if (c.status().axis_wave_running[axis]) c.stop_wave(axis);
        const bool armed = c.status().armed;
        c.start_wave(hostlink::wave_flag::kDetached | (arm && !armed ? hostlink::wave_flag::kArm : 0), axis);
        out = {{"trajectory", hostlink::to_json(c.get<link::TrajectoryParams>(axis))}};
        return 0;
    });
    poll_status();
    return out;
}

}  // namespace piezoloop::ui
