#include "link/params_json.hpp"

#include <stdexcept>

#include "link/client.hpp"

namespace piezoloop::hostlink {

using nlohmann::json;

namespace {

// Walks a JSON object of one group: each key must be consumed by a get_*
// call; done() rejects the ones left (typos).
class Obj {
public:
    Obj(const json& j, std::string path) : j_(j), path_(std::move(path)) {
        if (!j.is_object()) fail("", "must be a JSON object");
    }
    [[noreturn]] void fail(const std::string& key, const std::string& what) const {
        throw std::invalid_argument(path_ + (key.empty() ? "" : "." + key) + ": " + what);
    }
    const json* find(const char* key) {
        auto it = j_.find(key);
        if (it == j_.end()) return nullptr;
        used_.push_back(key);
        return &*it;
    }
    void f32(const char* key, float& v) {
        if (const json* x = find(key)) v = static_cast<float>(number(*x, key));
    }
    void f64(const char* key, double& v) {
        if (const json* x = find(key)) v = number(*x, key);
    }
    template <class I>
    void integer(const char* key, I& v, long long lo, long long hi) {
        if (const json* x = find(key)) {
            if (!x->is_number_integer()) fail(key, "must be an integer");
            const long long n = x->get<long long>();
            if (n < lo || n > hi) fail(key, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
            v = static_cast<I>(n);
        }
    }
    void boolean(const char* key, bool& v) {
        if (const json* x = find(key)) {
            if (!x->is_boolean()) fail(key, "must be true or false");
            v = x->get<bool>();
        }
    }
    const json* object(const char* key) {
        const json* x = find(key);
        if (x != nullptr && !x->is_object()) fail(key, "must be a JSON object");
        return x;
    }
    const json* array(const char* key) {
        const json* x = find(key);
        if (x != nullptr && !x->is_array()) fail(key, "must be an array");
        return x;
    }
    template <class E, std::size_t N>
    void enumeration(const char* key, E& v, const char* const (&names)[N]) {
        if (const json* x = find(key)) {
            std::string all;
            for (std::size_t i = 0; i < N; ++i) {
                if (x->is_string() && x->get<std::string>() == names[i]) {
                    v = static_cast<E>(i);
                    return;
                }
                all += (i ? ", " : "") + std::string(names[i]);
            }
            fail(key, "must be one of " + all);
        }
    }
    void done() const {
        for (auto it = j_.begin(); it != j_.end(); ++it) {
            bool known = false;
            for (const std::string& u : used_) known = known || u == it.key();
            if (!known) fail(it.key(), "unknown field");
        }
    }
    double number(const json& x, const std::string& key) const {
        if (!x.is_number()) fail(key, "must be a number");
        return x.get<double>();
    }
    const std::string& path() const { return path_; }

private:
    const json& j_;
    std::string path_;
    std::vector<std::string> used_;
};

const char* const kFeedforwardKinds[] = {"none", "pi_inverse", "pi_compensator", "dahl", "pi_series"};
const char* const kFeedbackKinds[] = {"none", "sos", "pid"};
const char* const kWaveforms[] = {"sine", "triangle", "raster", "square", "steps", "table"};
const char* const kModes[] = {"single_shot", "continuous"};
const char* const kTriggers[] = {"immediate", "rising", "falling"};
const char* const kSignals[] = {"r", "y", "e", "u", "u_ff", "u_fb", "u_rc"};
const char* const kRecorderStates[] = {"idle", "armed", "triggered", "done"};

template <std::size_t N>
json name_of(const char* const (&names)[N], unsigned v) {
    return v < N ? json(names[v]) : json(v);
}

json section_json(const SosSection& s) { return {{"b0", s.b0}, {"b1", s.b1}, {"b2", s.b2}, {"a1", s.a1}, {"a2", s.a2}}; }

void merge_section(const json& j, const std::string& path, SosSection& s) {
    Obj o(j, path);
    o.f64("b0", s.b0); o.f64("b1", s.b1); o.f64("b2", s.b2); o.f64("a1", s.a1); o.f64("a2", s.a2);
    o.done();
}

template <std::size_t N>
void float_array(Obj& o, const char* key, std::array<float, N>& out, int& count, int max_count) {
    if (const json* a = o.array(key)) {
        if (a->size() > static_cast<std::size_t>(max_count))
            o.fail(key, "at most " + std::to_string(max_count) + " values");
        if (count >= 0 && a->size() != static_cast<std::size_t>(count)) o.fail(key, "must have as many values as thresholds");
        for (std::size_t i = 0; i < a->size(); ++i) out[i] = static_cast<float>(o.number((*a)[i], std::string(key) + "[" + std::to_string(i) + "]"));
        count = static_cast<int>(a->size());
    }
}

}  // namespace

link::ParamGroup parse_group(const std::string& name) {
    for (int g = 1; g <= 6; ++g)
        if (name == link::group_name(static_cast<link::ParamGroup>(g))) return static_cast<link::ParamGroup>(g);
    throw std::invalid_argument("unknown parameter group '" + name +
                                "' (feedforward, feedback, rc, limits, trajectory, recorder, all)");
}

uint8_t parse_signal(const std::string& name) {
    for (uint8_t i = 0; i < 7; ++i)
        if (name == kSignals[i]) return i;
    throw std::invalid_argument("unknown signal '" + name + "' (r, y, e, u, u_ff, u_fb, u_rc)");
}

const char* waveform_name(Waveform w) {
    const auto i = static_cast<unsigned>(w);
    return i < 6 ? kWaveforms[i] : "?";
}

Waveform parse_waveform(const std::string& name) {
    for (unsigned i = 0; i < 6; ++i)
        if (name == kWaveforms[i]) return static_cast<Waveform>(i);
    throw std::invalid_argument("unknown waveform '" + name + "' (sine, triangle, raster, square, steps, table)");
}

json to_json(const link::FeedforwardParams& g) {
    json th = json::array(), w = json::array();
    for (int i = 0; i < g.pi.count && i < kMaxPlayOperators; ++i) {
        th.push_back(g.pi.thresholds[static_cast<unsigned>(i)]);
        w.push_back(g.pi.weights[static_cast<unsigned>(i)]);
    }
    const DahlParams& d = g.dahl;
    return {{"kind", name_of(kFeedforwardKinds, static_cast<unsigned>(g.kind))},
            {"pi", {{"input_gain", g.pi.input_gain}, {"input_offset", g.pi.input_offset}, {"p0", g.pi.p0},
                    {"thresholds", th}, {"weights", w}}},
            {"dahl", {{"alpha1", d.alpha1}, {"alpha2", d.alpha2}, {"beta1", d.beta1}, {"beta2", d.beta2},
                      {"gamma_a", d.gamma_a}, {"ga", d.ga}}}};
}

void merge_json(const json& j, link::FeedforwardParams& g) {
    Obj o(j, "feedforward");
    o.enumeration("kind", g.kind, kFeedforwardKinds);
    if (const json* p = o.object("pi")) {
        Obj q(*p, "feedforward.pi");
        q.f32("input_gain", g.pi.input_gain);
        q.f32("input_offset", g.pi.input_offset);
        q.f32("p0", g.pi.p0);
        int count = -1;
        float_array(q, "thresholds", g.pi.thresholds, count, kMaxPlayOperators);
        if (count < 0 && q.find("weights") != nullptr) count = g.pi.count;  // weights alone: keep the count
        int wc = count;
        float_array(q, "weights", g.pi.weights, wc, kMaxPlayOperators);
        if (count >= 0) {
            g.pi.count = count;
            for (int i = count; i < kMaxPlayOperators; ++i) {
                g.pi.thresholds[static_cast<unsigned>(i)] = 0.0f;
                g.pi.weights[static_cast<unsigned>(i)] = 0.0f;
            }
        }
        q.done();
    }
    if (const json* p = o.object("dahl")) {
        Obj q(*p, "feedforward.dahl");
        DahlParams& d = g.dahl;
        q.f32("alpha1", d.alpha1); q.f32("alpha2", d.alpha2); q.f32("beta1", d.beta1);
        q.f32("beta2", d.beta2); q.f32("gamma_a", d.gamma_a); q.f32("ga", d.ga);
        q.done();
    }
    o.done();
}

json to_json(const link::FeedbackParams& g) {
    json sec = json::array();
    for (int i = 0; i < g.sos_count && i < kMaxControllerSections; ++i) sec.push_back(section_json(g.sos[static_cast<unsigned>(i)]));
    const PidConfig& p = g.pid;
    return {{"kind", name_of(kFeedbackKinds, static_cast<unsigned>(g.kind))},
            {"sos_count", g.sos_count},
            {"sections", sec},
            {"pid", {{"kp", p.kp}, {"ki_per_s", p.ki_per_s}, {"kd_s", p.kd_s},
                     {"derivative_cutoff_Hz", p.derivative_cutoff_Hz}, {"u_min", p.u_min}, {"u_max", p.u_max}}}};
}

void merge_json(const json& j, link::FeedbackParams& g) {
    Obj o(j, "feedback");
    o.enumeration("kind", g.kind, kFeedbackKinds);
    if (const json* a = o.array("sections")) {
        if (a->size() > static_cast<std::size_t>(kMaxControllerSections))
            o.fail("sections", "at most " + std::to_string(kMaxControllerSections) + " sections");
        for (std::size_t i = 0; i < a->size(); ++i) merge_section((*a)[i], "feedback.sections[" + std::to_string(i) + "]", g.sos[i]);
        for (std::size_t i = a->size(); i < static_cast<std::size_t>(kMaxControllerSections); ++i) g.sos[i] = SosSection{};
        g.sos_count = static_cast<int>(a->size());
    }
    o.integer("sos_count", g.sos_count, 0, kMaxControllerSections);
    if (const json* p = o.object("pid")) {
        Obj q(*p, "feedback.pid");
        PidConfig& c = g.pid;
        q.f32("kp", c.kp); q.f32("ki_per_s", c.ki_per_s); q.f32("kd_s", c.kd_s);
        q.f32("derivative_cutoff_Hz", c.derivative_cutoff_Hz); q.f32("u_min", c.u_min); q.f32("u_max", c.u_max);
        q.done();
    }
    o.done();
}

json to_json(const link::RepetitiveParams& g) {
    return {{"enabled", g.enabled}, {"period_samples", g.rc.period_samples}, {"m1", g.rc.m1},
            {"m2", g.rc.m2},        {"k_rc", g.rc.k_rc},                     {"q", section_json(g.rc.q)}};
}

void merge_json(const json& j, link::RepetitiveParams& g) {
    Obj o(j, "rc");
    o.boolean("enabled", g.enabled);
    o.integer("period_samples", g.rc.period_samples, INT32_MIN, INT32_MAX);
    o.integer("m1", g.rc.m1, INT32_MIN, INT32_MAX);
    o.integer("m2", g.rc.m2, INT32_MIN, INT32_MAX);
    o.f32("k_rc", g.rc.k_rc);
    if (const json* q = o.object("q")) merge_section(*q, "rc.q", g.rc.q);
    o.done();
}

json to_json(const link::LimitsParams& g) {
    const LimitsConfig& l = g.limits;
    return {{"u_min_V", l.u_min_V}, {"u_max_V", l.u_max_V}, {"slew_V_per_s", l.slew_V_per_s},
            {"saturation_trip_s", l.saturation_trip_s}};
}

void merge_json(const json& j, link::LimitsParams& g) {
    Obj o(j, "limits");
    o.f32("u_min_V", g.limits.u_min_V);
    o.f32("u_max_V", g.limits.u_max_V);
    o.f32("slew_V_per_s", g.limits.slew_V_per_s);
    o.f32("saturation_trip_s", g.limits.saturation_trip_s);
    o.done();
}

json to_json(const link::TrajectoryParams& g) {
    json t = json::array();
    for (std::size_t i = 0; i < g.table_count && i < g.table.size(); ++i) t.push_back(g.table[i]);
    return {{"waveform", name_of(kWaveforms, static_cast<unsigned>(g.waveform))},
            {"amplitude_um", g.amplitude_um},
            {"offset_um", g.offset_um},
            {"frequency_Hz", g.frequency_Hz},
            {"cycles", g.cycles},
            {"start_phase_cycles", g.start_phase_cycles},
            {"return_fraction", g.return_fraction},
            {"duty", g.duty},
            {"table", t}};
}

void merge_json(const json& j, link::TrajectoryParams& g) {
    Obj o(j, "trajectory");
    o.enumeration("waveform", g.waveform, kWaveforms);
    o.f32("amplitude_um", g.amplitude_um);
    o.f32("offset_um", g.offset_um);
    o.f32("frequency_Hz", g.frequency_Hz);
    o.integer("cycles", g.cycles, 0, UINT32_MAX);
    o.f32("start_phase_cycles", g.start_phase_cycles);
    o.f32("return_fraction", g.return_fraction);
    o.f32("duty", g.duty);
    if (const json* a = o.array("table")) {
        if (a->size() > link::kMaxWaveTable) o.fail("table", "at most 96 values");
        g.table = {};
        for (std::size_t i = 0; i < a->size(); ++i) g.table[i] = static_cast<float>(o.number((*a)[i], "table"));
        g.table_count = static_cast<uint16_t>(a->size());
    }
    o.done();
}

json to_json(const link::RecorderParams& g) {
    json ch = json::array();
    for (std::size_t i = 0; i < g.channel_count && i < g.channels.size(); ++i) ch.push_back(name_of(kSignals, g.channels[i]));
    return {{"channels", ch},
            {"decimation", g.decimation},
            {"mode", name_of(kModes, static_cast<unsigned>(g.mode))},
            {"trigger", name_of(kTriggers, static_cast<unsigned>(g.trigger))},
            {"trigger_signal", name_of(kSignals, g.trigger_signal)},
            {"trigger_level", g.trigger_level},
            {"pre_trigger", g.pre_trigger},
            {"length", g.length}};
}

void merge_json(const json& j, link::RecorderParams& g) {
    Obj o(j, "recorder");
    if (const json* a = o.array("channels")) {
        if (a->size() > link::kMaxLogChannels) o.fail("channels", "at most 8 channels");
        g.channels = {};
        for (std::size_t i = 0; i < a->size(); ++i) {
            if (!(*a)[i].is_string()) o.fail("channels", "signal names (r, y, e, u, u_ff, u_fb, u_rc)");
            g.channels[i] = parse_signal((*a)[i].get<std::string>());
        }
        g.channel_count = static_cast<uint8_t>(a->size());
    }
    o.integer("decimation", g.decimation, 0, UINT32_MAX);
    o.enumeration("mode", g.mode, kModes);
    o.enumeration("trigger", g.trigger, kTriggers);
    o.enumeration("trigger_signal", g.trigger_signal, kSignals);
    o.f32("trigger_level", g.trigger_level);
    o.integer("pre_trigger", g.pre_trigger, 0, UINT32_MAX);
    o.integer("length", g.length, 0, UINT32_MAX);
    o.done();
}

json to_json(const link::HelloReply& h) {
    json caps = json::array();
    const char* const cap_names[] = {"float", "q31", "dahl", "repetitive", "setpoint_stream", "recorder", "wave_table"};
    for (unsigned i = 0; i < 7; ++i)
        if (h.capabilities & (1u << i)) caps.push_back(cap_names[i]);
    return {{"protocol_version", h.protocol_version},
            {"board", h.board.data()},
            {"firmware_version", h.firmware_version.data()},
            {"serial", h.serial.data()},
            {"loop_rate_Hz", h.loop_rate_Hz},
            {"capabilities", caps},
            {"sample_format", h.sample_format == link::SampleFormat::kQ31 ? "q31" : "float32"},
            {"hard_limits", {{"u_min_V", h.hard_u_min_V}, {"u_max_V", h.hard_u_max_V},
                             {"slew_max_V_per_s", h.hard_slew_max_V_per_s}}},
            {"position_full_scale_um", h.position_full_scale_um},
            {"voltage_full_scale_V", h.voltage_full_scale_V},
            {"max_payload", h.max_payload},
            {"setpoint_capacity", h.setpoint_capacity},
            {"recorder_channels", h.recorder_channels},
            {"recorder_capacity", h.recorder_capacity},
            {"max_sos_sections", h.max_sos_sections},
            {"max_play_operators", h.max_play_operators},
            {"max_wave_table", h.max_wave_table},
            {"rc_capacity", h.rc_capacity}};
}

json to_json(const link::StatusReply& s) {
    json faults = json::array();
    const char* const fault_names[] = {"hard_limits_invalid", "tick_overrun", "setpoint_underrun", "recorder_overrun",
                                       "link_errors"};
    for (unsigned i = 0; i < 5; ++i)
        if (s.faults & (1u << i)) faults.push_back(fault_names[i]);
    if (s.faults >> 8) faults.push_back("board_faults");
    const link::LinkCounters& c = s.link;
    return {{"armed", s.armed},
            {"tripped", s.tripped},
            {"trip_reason", trip_reason_name(s.trip_reason)},
            {"wave_running", s.wave_running},
            {"streaming", s.streaming},
            {"swap_pending", s.swap_pending},
            {"recorder_state", name_of(kRecorderStates, static_cast<unsigned>(s.recorder_state))},
            {"faults", faults},
            {"faults_bits", s.faults},
            {"tick_count", s.tick_count},
            {"swaps", s.swaps},
            {"tick", {{"overruns", s.tick.overruns}, {"time_min", s.tick.time_min}, {"time_max", s.tick.time_max},
                      {"time_mean", s.tick.time_mean}, {"counter_Hz", s.tick.counter_Hz},
                      {"board_faults", s.tick.board_faults}}},
            {"setpoint_underruns", s.setpoint_underruns},
            {"setpoint_free", s.setpoint_free},
            {"setpoint_next_seq", s.setpoint_next_seq},
            {"recorder_overruns", s.recorder_overruns},
            {"log_blocks", s.log_blocks},
            {"link", {{"frames_ok", c.frames_ok}, {"bad_cobs", c.bad_cobs}, {"bad_crc", c.bad_crc},
                      {"truncated", c.truncated}, {"oversize", c.oversize}, {"unknown_type", c.unknown_type},
                      {"bad_version", c.bad_version}, {"bad_length", c.bad_length}, {"bad_value", c.bad_value},
                      {"error_replies", c.error_replies}}},
            {"r_um", s.r_um},
            {"y_um", s.y_um},
            {"u_V", s.u_V}};
}

}  // namespace piezoloop::hostlink
