#include "link/params_json.hpp"

#include <cstdio>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "piezoloop/params/field.hpp"

namespace piezoloop::hostlink {

using nlohmann::json;
using params::Field;
using params::Travel;

namespace {

template <class X>
json value_json(const Field& f, const X& x) {
    if constexpr (std::is_enum_v<X>) {
        return value_json(f, static_cast<std::underlying_type_t<X>>(x));
    } else {
        if (f.is_enum()) {
            const auto i = static_cast<unsigned>(x);
            return i < f.name_count ? json(f.names[i]) : json(i);
        }
        if (f.wire == params::Wire::kBool) return json(static_cast<bool>(x));
        if (f.is_number()) return json(static_cast<double>(x));  // every float is a double: exact
        if constexpr (std::is_signed_v<X>) return json(static_cast<long long>(x));
        else return json(static_cast<unsigned long long>(x));
    }
}

template <class C>
std::size_t in_use(const C& n, std::size_t capacity) {
    if constexpr (std::is_signed_v<C>)
        if (n < 0) return 0;
    return static_cast<std::size_t>(n) < capacity ? static_cast<std::size_t>(n) : capacity;
}

// Group -> JSON: nested objects as declared, arrays with their elements in
// use (the count is the array's length), enums by name.
class JsonWriter {
public:
    json root = json::object();

    template <class X>
    void value(const Field& f, const X& x) {
        (*top())[f.name] = value_json(f, x);
    }
    void begin(const char* name) {
        (*top())[name] = json::object();
        stack_.push_back(&(*top())[name]);
    }
    void end() { stack_.pop_back(); }
    template <class C>
    void count(const Field&, const C&) {}
    template <class X, std::size_t N, class C>
    void values(const Field& f, const std::array<X, N>& a, const C& n, Travel) {
        json arr = json::array();
        for (std::size_t i = 0; i < in_use(n, N); ++i) arr.push_back(value_json(f, a[i]));
        (*top())[f.name] = arr;
    }
    template <class S, std::size_t N, class C>
    void objects(const char* name, const std::array<S, N>& a, const C& n, Travel) {
        json arr = json::array();
        for (std::size_t i = 0; i < in_use(n, N); ++i) {
            JsonWriter element;
            params::describe(element, a[i]);
            arr.push_back(element.root);
        }
        (*top())[name] = arr;
    }

private:
    json* top() { return stack_.empty() ? &root : stack_.back(); }
    std::vector<json*> stack_;
};

// JSON -> group, merged onto the group's current values: only the keys given
// change. Each object level must use all its keys (a typo is an error). An
// array sets the count it shares with later arrays (PI thresholds and
// weights), which must then have as many values.
class JsonMerger {
public:
    JsonMerger(const json& j, std::string path) { push(&j, std::move(path)); }

    [[noreturn]] void fail(const std::string& key, const std::string& what) const {
        const std::string& p = levels_.back().path;
        throw std::invalid_argument(p + (key.empty() ? "" : "." + key) + ": " + what);
    }

    template <class X>
    void value(const Field& f, X& x) {
        if (const json* v = find(f.name)) x = parse<X>(f, *v, f.name);
    }
    void begin(const char* name) {
        const json* v = find(name);
        push(v, levels_.back().path + "." + name);
    }
    void end() {
        done();
        levels_.pop_back();
    }
    template <class C>
    void count(const Field&, C&) {
        levels_.back().count_owner_array.clear();
    }
    template <class X, std::size_t N, class C>
    void values(const Field& f, std::array<X, N>& a, C& n, Travel t) {
        declare_array(f.name);
        const json* v = find(f.name);
        if (v == nullptr) {
            // A count changed by an earlier array: what lies beyond it is unused.
            if (t == Travel::kCount)
                for (std::size_t i = in_use(n, N); i < N; ++i) a[i] = X{};
            return;
        }
        const std::size_t size = array_size(*v, f.name, N);
        if (t == Travel::kAll) a = {};
        for (std::size_t i = 0; i < size; ++i)
            a[i] = parse<X>(f, (*v)[i], std::string(f.name) + "[" + std::to_string(i) + "]");
        for (std::size_t i = size; i < N; ++i) a[i] = X{};
        set_count(f.name, n, size);
    }
    template <class S, std::size_t N, class C>
    void objects(const char* name, std::array<S, N>& a, C& n, Travel) {
        declare_array(name);
        const json* v = find(name);
        if (v == nullptr) return;
        const std::size_t size = array_size(*v, name, N);
        for (std::size_t i = 0; i < size; ++i) {
            JsonMerger element((*v)[i], levels_.back().path + "." + name + "[" + std::to_string(i) + "]");
            params::describe(element, a[i]);
            element.done();
        }
        for (std::size_t i = size; i < N; ++i) a[i] = S{};
        set_count(name, n, size);
    }

    void done() const {
        const Level& l = levels_.back();
        if (l.j == nullptr) return;
        for (auto it = l.j->begin(); it != l.j->end(); ++it) {
            bool known = false;
            for (const std::string& u : l.used) known = known || u == it.key();
            if (!known) fail(it.key(), "unknown field");
        }
    }

private:
    struct Level {
        const json* j = nullptr;  // null: the object is not given, nothing changes
        std::string path;
        std::vector<std::string> used;
        std::string count_owner_array;  // the first array declared after the last count
    };

    void push(const json* j, std::string path) {
        Level l;
        l.j = j;
        l.path = std::move(path);
        levels_.push_back(std::move(l));
        if (j != nullptr && !j->is_object()) fail("", "must be a JSON object");
    }

    const json* find(const char* key) {
        Level& l = levels_.back();
        if (l.j == nullptr) return nullptr;
        auto it = l.j->find(key);
        if (it == l.j->end()) return nullptr;
        l.used.emplace_back(key);
        return &*it;
    }

    std::size_t array_size(const json& v, const char* key, std::size_t capacity) const {
        if (!v.is_array()) fail(key, "must be an array");
        if (v.size() > capacity) fail(key, "at most " + std::to_string(capacity) + " values");
        return v.size();
    }

    // The first array declared after a count sets it; later arrays of the
    // same count must have as many values.
    void declare_array(const char* key) {
        if (levels_.back().count_owner_array.empty()) levels_.back().count_owner_array = key;
    }
    template <class C>
    void set_count(const char* key, C& n, std::size_t size) {
        const Level& l = levels_.back();
        if (l.count_owner_array == key)
            n = static_cast<C>(size);
        else if (size != in_use(n, static_cast<std::size_t>(-1)))
            fail(key, "must have as many values as " + l.count_owner_array);
    }

    template <class X>
    X parse(const Field& f, const json& v, const std::string& key) const {
        if constexpr (std::is_enum_v<X>) {
            return static_cast<X>(parse<std::underlying_type_t<X>>(f, v, key));
        } else {
            if (f.is_enum()) {
                std::string all;
                for (unsigned i = 0; i < f.name_count; ++i) {
                    if (v.is_string() && v.get<std::string>() == f.names[i]) return static_cast<X>(i);
                    all += (i ? ", " : "") + std::string(f.names[i]);
                }
                fail(key, "must be one of " + all);
            }
            if (f.wire == params::Wire::kBool) {
                if (!v.is_boolean()) fail(key, "must be true or false");
                return static_cast<X>(v.get<bool>());
            }
            if (f.is_number()) {
                if (!v.is_number()) fail(key, "must be a number");
                const double d = v.get<double>();
                if (!(d >= -params::kFloatMax && d <= params::kFloatMax))
                    fail(key, "must be finite in float32 (|x| <= 3.4028e+38)");
                return static_cast<X>(d);
            }
            if (!v.is_number_integer()) fail(key, "must be an integer");
            const double d = v.is_number_unsigned() ? static_cast<double>(v.get<unsigned long long>())
                                                    : static_cast<double>(v.get<long long>());
            if (d < f.min || d > f.max) {
                char t[96];
                std::snprintf(t, sizeof t, "must be in [%.0f, %.0f]", f.min, f.max);
                fail(key, t);
            }
            return static_cast<X>(d);
        }
    }

    std::vector<Level> levels_;
};

template <class G>
json group_json(const G& g) {
    JsonWriter w;
    params::describe(w, g);
    return w.root;
}

template <class G>
void merge_group(const json& j, G& g) {
    JsonMerger m(j, params::group_name(G::kGroup));
    params::describe(m, g);
    m.done();
}

}  // namespace

json to_json(const link::FeedforwardParams& g) { return group_json(g); }
json to_json(const link::FeedbackParams& g) { return group_json(g); }
json to_json(const link::RepetitiveParams& g) { return group_json(g); }
json to_json(const link::LimitsParams& g) { return group_json(g); }
json to_json(const link::TrajectoryParams& g) { return group_json(g); }
json to_json(const link::RecorderParams& g) { return group_json(g); }
json to_json(const link::LinkParams& g) { return group_json(g); }

void merge_json(const json& j, link::FeedforwardParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::FeedbackParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::RepetitiveParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::LimitsParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::TrajectoryParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::RecorderParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::LinkParams& g) { merge_group(j, g); }

namespace {

template <std::size_t N>
std::string name_list(const char* const (&names)[N]) {
    std::string all;
    for (std::size_t i = 0; i < N; ++i) all += (i ? ", " : "") + std::string(names[i]);
    return all;
}

template <std::size_t N>
json name_of(const char* const (&names)[N], unsigned v) {
    return v < N ? json(names[v]) : json(v);
}

}  // namespace

link::ParamGroup parse_group(const std::string& name) {
    for (int g = 1; g <= params::kGroupCount; ++g)
        if (name == link::group_name(static_cast<link::ParamGroup>(g))) return static_cast<link::ParamGroup>(g);
    std::string all;
    for (int g = 1; g <= params::kGroupCount; ++g) all += std::string(link::group_name(static_cast<link::ParamGroup>(g))) + ", ";
    throw std::invalid_argument("unknown parameter group '" + name + "' (" + all + "all)");
}

uint8_t parse_signal(const std::string& name) {
    for (uint8_t i = 0; i < std::size(params::kSignalNames); ++i)
        if (name == params::kSignalNames[i]) return i;
    throw std::invalid_argument("unknown signal '" + name + "' (" + name_list(params::kSignalNames) + ")");
}

const char* waveform_name(Waveform w) {
    const auto i = static_cast<unsigned>(w);
    return i < std::size(params::kWaveformNames) ? params::kWaveformNames[i] : "?";
}

Waveform parse_waveform(const std::string& name) {
    for (unsigned i = 0; i < std::size(params::kWaveformNames); ++i)
        if (name == params::kWaveformNames[i]) return static_cast<Waveform>(i);
    throw std::invalid_argument("unknown waveform '" + name + "' (" + name_list(params::kWaveformNames) + ")");
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
    const char* const recorder_states[] = {"idle", "armed", "triggered", "done"};
    json faults = json::array();
    const char* const fault_names[] = {"hard_limits_invalid", "tick_overrun", "setpoint_underrun", "recorder_overrun",
                                       "link_errors", "client_lost"};
    for (unsigned i = 0; i < std::size(fault_names); ++i)
        if (s.faults & (1u << i)) faults.push_back(fault_names[i]);
    if (s.faults >> 8) faults.push_back("board_faults");
    const link::LinkCounters& c = s.link;
    return {{"armed", s.armed},
            {"tripped", s.tripped},
            {"trip_reason", trip_reason_name(s.trip_reason)},
            {"wave_running", s.wave_running},
            {"streaming", s.streaming},
            {"swap_pending", s.swap_pending},
            {"recorder_state", name_of(recorder_states, static_cast<unsigned>(s.recorder_state))},
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
