#include "link/params_json.hpp"

#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "json/json_reader.hpp"
#include "piezoloop/params/field.hpp"
#include "status_text.hpp"

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
// change. Read with the host's one JSON reader (host/json), so every error
// names the field's path; each object level must use only its declared keys
// (a typo is an error). An array sets the count it shares with later arrays
// (PI thresholds and weights), which must then have as many values.
class JsonMerger {
public:
    explicit JsonMerger(const hostjson::Field& f) { push(f); }

    template <class X>
    void value(const Field& f, X& x) {
        if (const auto v = find(f.name)) x = parse<X>(f, *v);
    }
    void begin(const char* name) {
        const auto v = find(name);
        if (v)
            push(*v);
        else
            levels_.emplace_back();
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
        const auto v = find(f.name);
        if (!v) {
            // A count changed by an earlier array: what lies beyond it is unused.
            if (t == Travel::kCount)
                for (std::size_t i = in_use(n, N); i < N; ++i) a[i] = X{};
            return;
        }
        const std::size_t size = v->size(N);
        if (t == Travel::kAll) a = {};
        for (std::size_t i = 0; i < size; ++i) a[i] = parse<X>(f, v->at(i));
        for (std::size_t i = size; i < N; ++i) a[i] = X{};
        set_count(*v, f.name, n, size);
    }
    template <class S, std::size_t N, class C>
    void objects(const char* name, std::array<S, N>& a, C& n, Travel) {
        declare_array(name);
        const auto v = find(name);
        if (!v) return;
        const std::size_t size = v->size(N);
        for (std::size_t i = 0; i < size; ++i) {
            JsonMerger element(v->at(i));
            params::describe(element, a[i]);
            element.done();
        }
        for (std::size_t i = size; i < N; ++i) a[i] = S{};
        set_count(*v, name, n, size);
    }

    void done() const {
        const Level& l = levels_.back();
        if (l.field) l.field->only(l.declared);
    }

private:
    struct Level {
        std::optional<hostjson::Field> field;  // none: the object is not given, nothing changes
        std::vector<std::string> declared;
        std::string count_owner_array;  // the first array declared after the last count
    };

    void push(const hostjson::Field& f) {
        if (!f.is_object()) f.fail("must be a JSON object");
        levels_.emplace_back();
        levels_.back().field = f;
    }

    std::optional<hostjson::Field> find(const char* key) {
        Level& l = levels_.back();
        l.declared.emplace_back(key);
        if (!l.field) return std::nullopt;
        return l.field->get(key);
    }

    void declare_array(const char* key) {
        if (levels_.back().count_owner_array.empty()) levels_.back().count_owner_array = key;
    }
    template <class C>
    void set_count(const hostjson::Field& v, const char* key, C& n, std::size_t size) {
        const Level& l = levels_.back();
        if (l.count_owner_array == key)
            n = static_cast<C>(size);
        else if (size != in_use(n, static_cast<std::size_t>(-1)))
            v.fail("must have as many values as " + l.count_owner_array);
    }

    template <class X>
    static X parse(const Field& f, const hostjson::Field& v) {
        if constexpr (std::is_enum_v<X>) {
            return static_cast<X>(parse<std::underlying_type_t<X>>(f, v));
        } else {
            if (f.is_enum()) return static_cast<X>(v.enumeration(f.names, f.name_count));
            if (f.wire == params::Wire::kBool) return static_cast<X>(v.boolean());
            // Numbers must be finite in float32, the core's type, whatever
            // their wire type: the board checks the same after conversion.
            if (f.is_number()) return f.wire == params::Wire::kF64 ? static_cast<X>(v.number_in_f32_range())
                                                                     : static_cast<X>(v.number_f32());
            return static_cast<X>(v.integer64(static_cast<long long>(f.min), static_cast<long long>(f.max)));
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
    JsonMerger m(hostjson::Field(j, params::group_name(G::kGroup)));
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
json to_json(const link::InputMatrixParams& g) { return group_json(g); }
json to_json(const link::OutputMatrixParams& g) { return group_json(g); }

void merge_json(const json& j, link::FeedforwardParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::FeedbackParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::RepetitiveParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::LimitsParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::TrajectoryParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::RecorderParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::LinkParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::InputMatrixParams& g) { merge_group(j, g); }
void merge_json(const json& j, link::OutputMatrixParams& g) { merge_group(j, g); }

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
    const char* const cap_names[] = {"float",    "q31",        "dahl",       "repetitive", "setpoint_stream",
                                     "recorder", "wave_table", "excitation", "storage"};
    for (unsigned i = 0; i < std::size(cap_names); ++i)
        if (h.capabilities & (1u << i)) caps.push_back(cap_names[i]);
    json j = {{"protocol_version", h.protocol_version},
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
            {"rc_capacity", h.rc_capacity},
            {"excitation_capacity", h.excitation_capacity},
            {"axis_count", h.axis_count}};
    // A board of axes: each axis's full scales and hard limits.
    if (h.axis_count > 1) {
        j["axes"] = json::array();
        for (std::size_t a = 0; a < h.axis_count && a < link::kMaxLinkAxes; ++a)
            j["axes"].push_back({{"position_full_scale_um", h.axis_position_full_scale_um[a]},
                                 {"voltage_full_scale_V", h.axis_voltage_full_scale_V[a]},
                                 {"hard_limits", {{"u_min_V", h.axis_hard_u_min_V[a]}, {"u_max_V", h.axis_hard_u_max_V[a]},
                                                  {"slew_max_V_per_s", h.axis_hard_slew_max_V_per_s[a]}}}});
    }
    return j;
}

namespace {

// The stored parameter set at boot: its state in words, and why it was
// ignored (the check that failed, as "group.field[index]: message").
json storage_json(const link::StatusReply& s) {
    json j = {{"at_boot", link::storage_state_name(s.storage)}, {"text", storage_state_text(s.storage)}};
    if (s.storage_field[0] != '\0') {
        Status why;
        why.group = s.storage_group[0] != '\0' ? s.storage_group.data() : nullptr;
        why.field = s.storage_field.data();
        why.index = s.storage_index;
        why.message = s.storage_message.data();
        j["why"] = describe(why);
    }
    return j;
}

}  // namespace

json axis_status_json(const link::StatusReply& st, int a) {
    const std::size_t i = static_cast<std::size_t>(a);
    return {{"axis", std::string(1, "xyz"[a % 3])},
            {"armed", st.axis_armed[i]},
            {"tripped", st.axis_tripped[i]},
            {"trip_reason", trip_reason_name(static_cast<TripReason>(st.axis_trip_reason[i]))},
            {"wave_running", st.axis_wave_running[i]},
            {"excitation_running", st.axis_excitation_running[i]},
            {"swaps", st.axis_swaps[i]},
            {"r_um", st.axis_r_um[i]},
            {"y_um", st.axis_y_um[i]},
            {"u_V", st.axis_u_V[i]},
            {"channel_u_V", st.channel_u_V[i]},
            {"channel_clamped", st.channel_clamped[i]},
            {"channel_slew_limited", st.channel_slew_limited[i]}};
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
            {"u_V", s.u_V},
            {"excitation", {{"running", s.excitation_running}, {"ticks", s.excitation_ticks},
                            {"clipped", s.excitation_clipped}}},
            {"storage", storage_json(s)}};
}

}  // namespace piezoloop::hostlink
