#include "link/params_schema.hpp"

#include <cstdio>
#include <string>
#include <type_traits>
#include <vector>

#include "link/params_json.hpp"
#include "piezoloop/link/messages.hpp"
#include "piezoloop/params/text_buffer.hpp"
#include "piezoloop/params/wire_codec.hpp"

namespace piezoloop::hostlink {

using nlohmann::json;
using params::Field;
using params::Travel;

namespace {

std::string number_text(double v) {
    params::TextBuffer<32> t;
    t.append_number(v);
    return t.c_str();
}

// The schema of one value (no default: the caller adds it).
json value_schema(const Field& f) {
    json s;
    if (f.is_enum()) {
        json names = json::array();
        for (unsigned i = 0; i < f.name_count; ++i) names.push_back(f.names[i]);
        s["enum"] = names;
    } else if (f.wire == params::Wire::kBool) {
        s["type"] = "boolean";
    } else {
        s["type"] = f.is_number() ? "number" : "integer";
        s[f.min_open ? "exclusiveMinimum" : "minimum"] = f.min;
        s[f.max_open ? "exclusiveMaximum" : "maximum"] = f.max;
    }
    if (f.unit[0] != '\0') s["unit"] = f.unit;
    s["wire"] = params::wire_name(f.wire);
    if (f.doc[0] != '\0') s["description"] = f.doc;
    return s;
}

// Visits a default-constructed group: its values are the defaults.
class SchemaWriter {
public:
    json root = object_schema();

    template <class X>
    void value(const Field& f, const X& x) {
        json s = value_schema(f);
        // A default the range refuses (the limits' zero slew: the board
        // starts with its limiter unconfigured) is no default at all.
        if (in_range(f, x)) s["default"] = default_json(f, x);
        if (f.critical) s["limitCritical"] = true;
        add(f.name, s);
    }
    void begin(const char* name) {
        add(name, object_schema());
        stack_.push_back(&(*top())["properties"][name]);
    }
    void end() { stack_.pop_back(); }
    template <class C>
    void count(const Field&, const C&) {}
    template <class X, std::size_t N, class C>
    void values(const Field& f, const std::array<X, N>& a, const C& n, Travel) {
        json s = {{"type", "array"}, {"maxItems", N}, {"items", value_schema(f)}};
        if (f.doc[0] != '\0') s["description"] = f.doc;
        json d = json::array();
        for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) d.push_back(default_json(f, a[i]));
        s["default"] = d;
        add(f.name, s);
    }
    template <class S, std::size_t N, class C>
    void objects(const char* name, const std::array<S, N>& a, const C&, Travel) {
        SchemaWriter element;
        params::describe(element, a[0]);
        add(name, {{"type", "array"}, {"maxItems", N}, {"items", element.root}, {"default", json::array()}});
    }

private:
    static json object_schema() {
        return {{"type", "object"}, {"properties", json::object()}, {"additionalProperties", false}};
    }
    template <class X>
    static json default_json(const Field& f, const X& x) {
        if constexpr (std::is_enum_v<X>) {
            return default_json(f, static_cast<std::underlying_type_t<X>>(x));
        } else {
            if (f.is_enum()) return f.names[static_cast<unsigned>(x)];
            if (f.wire == params::Wire::kBool) return static_cast<bool>(x);
            return static_cast<double>(x);
        }
    }
    template <class X>
    static bool in_range(const Field& f, const X& x) {
        double v = 0.0;
        if constexpr (std::is_enum_v<X>)
            v = static_cast<double>(static_cast<std::underlying_type_t<X>>(x));
        else
            v = static_cast<double>(x);
        return (f.min_open ? v > f.min : v >= f.min) && (f.max_open ? v < f.max : v <= f.max);
    }
    json* top() { return stack_.empty() ? &root : stack_.back(); }
    void add(const char* name, json s) { (*top())["properties"][name] = std::move(s); }
    std::vector<json*> stack_;
};

template <class G>
json group_schema(const char* doc) {
    SchemaWriter w;
    const G g{};
    params::describe(w, g);
    w.root["description"] = doc;
    w.root["groupId"] = static_cast<int>(G::kGroup);
    // An axis's group names its axis (0 = x, 1 = y, 2 = z); a board group axis 0.
    w.root["perAxis"] = !params::board_group(G::kGroup);
    return w.root;
}

// Markdown rows, one per field, with the path inside the group.
class TableWriter {
public:
    std::string rows;

    template <class X>
    void value(const Field& f, const X&) {
        row(f, params::wire_name(f.wire));
    }
    void begin(const char* name) { prefix_.push_back(std::string(name) + "."); }
    void end() { prefix_.pop_back(); }
    // Counted fields travel after their count: named by the latest one.
    template <class C>
    void count(const Field& f, const C&) {
        row(f, params::wire_name(f.wire));
        count_name_ = f.name;
    }
    template <class X, std::size_t N, class C>
    void values(const Field& f, const std::array<X, N>&, const C&, Travel t) {
        row(f, std::string(params::wire_name(f.wire)) + (t == Travel::kAll ? "[" + std::to_string(N) + "]" : "[" + count_name_ + "]"));
    }
    template <class S, std::size_t N, class C>
    void objects(const char* name, const std::array<S, N>& a, const C&, Travel t) {
        prefix_.push_back(std::string(name) + (t == Travel::kAll ? "[" + std::to_string(N) + "]." : "[" + count_name_ + "]."));
        params::describe(*this, a[0]);
        prefix_.pop_back();
    }

private:
    std::string count_name_ = "count";
    void row(const Field& f, const std::string& wire) {
        std::string path;
        for (const std::string& p : prefix_) path += p;
        path += f.name;
        std::string range;
        if (f.is_enum()) {
            for (unsigned i = 0; i < f.name_count; ++i) range += (i ? ", " : "") + std::to_string(i) + " " + f.names[i];
        } else if (f.wire == params::Wire::kBool) {
            range = "false, true";
        } else if (f.is_number() && f.min == -params::kFloatMax && f.max == params::kFloatMax) {
            range = "finite";
        } else {
            range = std::string(f.min_open ? "(" : "[") + number_text(f.min) + ", " + number_text(f.max) +
                    (f.max_open ? ")" : "]");
        }
        const std::string unit = f.unit[0] == '\0' || std::string(f.unit) == "1" ? "" : f.unit;
        rows += "| " + path + " | " + wire + " | " + unit + " | " + range + " | " + (f.critical ? "yes" : "") + " | " +
                f.doc + " |\n";
    }
    std::vector<std::string> prefix_;
};

template <class G>
std::string group_table() {
    TableWriter w;
    const G g{};
    params::describe(w, g);
    const params::LayoutSize size = params::layout_size<G>();
    std::string size_text = std::to_string(size.fixed + 2);  // + the group id and axis bytes
    for (int i = 0; i < size.count_fields; ++i) {
        const params::LayoutSize::Counted& c = size.counts[static_cast<std::size_t>(i)];
        if (c.per_element != 0) size_text += " + " + std::to_string(c.per_element) + "·" + c.name;
    }
    return "**" + std::to_string(static_cast<int>(G::kGroup)) + " " + params::group_name(G::kGroup) + "** (" + size_text +
           " bytes with the group id and the axis; " + (params::board_group(G::kGroup) ? "the board's" : "per axis") +
           ")\n\n| field | wire | unit | allowed | limit-critical | description |\n"
           "|---|---|---|---|---|---|\n" +
           w.rows + "\n";
}

}  // namespace

json parameter_schema() {
    json groups = json::object();
    groups["feedforward"] = group_schema<link::FeedforwardParams>("inverse hysteresis: PI model or Dahl");
    groups["feedback"] = group_schema<link::FeedbackParams>("feedback of e = r - y: SOS cascade or PID");
    groups["rc"] = group_schema<link::RepetitiveParams>("plug-in repetitive control");
    groups["limits"] = group_schema<link::LimitsParams>("runtime output limits, within the board's hard limits");
    groups["trajectory"] = group_schema<link::TrajectoryParams>("the wave generator (its rate is the loop rate)");
    groups["recorder"] = group_schema<link::RecorderParams>("the signal recorder");
    groups["link"] = group_schema<link::LinkParams>("what the board does when its client goes silent");
    groups["input_matrix"] =
        group_schema<link::InputMatrixParams>("sensor readings -> axis positions, with offsets (multi-axis boards)");
    groups["output_matrix"] =
        group_schema<link::OutputMatrixParams>("axis commands -> actuator channels (static decoupling)");
    return {{"$schema", "https://json-schema.org/draft/2020-12/schema"},
            {"title", "piezoloop parameter groups"},
            {"description",
             "Parameter groups of a piezoloop board (GetParams / SetParams), as `piezoloop --device ADDR get|set` "
             "reads and writes them. Ranges that depend on the board (loop rate, hard limits, capacities, the axis "
             "count) are in its hello reply. perAxis groups exist once per axis (--axis x|y|z), the others once per "
             "board. limitCritical fields change only while the loop is disarmed."},
            {"type", "object"},
            {"properties", groups},
            {"additionalProperties", false}};
}

std::string parameter_tables_markdown() {
    return group_table<link::FeedforwardParams>() + group_table<link::FeedbackParams>() +
           group_table<link::RepetitiveParams>() + group_table<link::LimitsParams>() +
           group_table<link::TrajectoryParams>() + group_table<link::RecorderParams>() + group_table<link::LinkParams>() +
           group_table<link::InputMatrixParams>() + group_table<link::OutputMatrixParams>();
}

}  // namespace piezoloop::hostlink
