#include "link/protocol_tables.hpp"

#include <cstdio>
#include <stdexcept>

#include "piezoloop/link/messages.hpp"
#include "piezoloop/params/wire_codec.hpp"

namespace piezoloop::hostlink {

using params::Field;
using params::Travel;

namespace {

std::string hex_id(link::MsgType t) {
    char id[8];
    std::snprintf(id, sizeof id, "0x%02X", static_cast<unsigned>(t));
    return id;
}

// "n" or "n + k·count".
std::string size_text(std::size_t fixed, std::size_t per_count) {
    std::string s = std::to_string(fixed);
    if (per_count != 0) s += " + " + std::to_string(per_count) + "·count";
    return s;
}

// Markdown rows, one per field, with the field's offset in the body.
class LayoutTable {
public:
    std::string rows;

    template <class X>
    void value(const Field& f, const X&) {
        row(f, params::wire_size(f.wire), 0, params::wire_name(f.wire));
    }
    void begin(const char* name) { prefix_ += std::string(name) + "."; }
    void end() {
        const std::size_t dot = prefix_.find_last_of('.', prefix_.size() - 2);
        prefix_.erase(dot == std::string::npos ? 0 : dot + 1);
    }
    template <class C>
    void count(const Field& f, const C& n) {
        value(f, n);
    }
    template <class X, std::size_t N, class C>
    void values(const Field& f, const std::array<X, N>&, const C&, Travel t) {
        const std::size_t one = params::wire_size(f.wire);
        if (t == Travel::kAll)
            row(f, N * one, 0, std::string(params::wire_name(f.wire)) + "[" + std::to_string(N) + "]");
        else
            row(f, 0, one, std::string(params::wire_name(f.wire)) + "[count]");
    }
    template <std::size_t N>
    void text(const Field& f, const std::array<char, N>&) {
        row(f, N, 0, "char[" + std::to_string(N) + "]");
    }

private:
    void row(const Field& f, std::size_t size, std::size_t per_count, const std::string& type) {
        const std::string unit = f.unit[0] == '\0' || std::string(f.unit) == "1" ? "" : f.unit;
        rows += "| " + size_text(offset_, offset_per_count_) + " | " + prefix_ + f.name + " | " +
                (per_count != 0 ? std::to_string(per_count) + "·count" : std::to_string(size)) + " | " + type + " | " +
                unit + " | " + f.doc + " |\n";
        offset_ += size;
        offset_per_count_ += per_count;
    }
    std::string prefix_;
    std::size_t offset_ = 0, offset_per_count_ = 0;
};

template <class M>
std::string layout_markdown(const char* name) {
    LayoutTable t;
    const M m{};
    describe(t, m);
    const params::LayoutSize size = params::layout_size<M>();
    return "**" + std::string(name) + " (" + hex_id(M::kType) + ")**, " + size_text(size.fixed, size.per_count()) +
           " bytes\n\n| off | field | size | type | unit | meaning |\n|---|---|---|---|---|---|\n" + t.rows;
}

struct Layout {
    const char* name;
    std::string (*markdown)(const char*);
};
// In the order docs/protocol.md has them.
const Layout kLayouts[] = {
    {"HelloReply", layout_markdown<link::HelloReply>},   {"StartExcitation", layout_markdown<link::StartExcitation>},
    {"StartScan", layout_markdown<link::StartScan>},
    {"Setpoints", layout_markdown<link::SetpointBlock>}, {"SetpointAck", layout_markdown<link::SetpointAck>},
    {"StatusReply", layout_markdown<link::StatusReply>}, {"LogBlock", layout_markdown<link::LogBlock>},
    {"Error", layout_markdown<link::ErrorReply>},
};

}  // namespace

std::string message_types_markdown() {
    std::string out = "| type | name | direction | body | reply |\n|---|---|---|---|---|\n";
    for (const link::MessageTypeDoc& m : link::kMessageTypes) {
        const uint8_t t = static_cast<uint8_t>(m.type);
        out += "| " + hex_id(m.type) + " | " + m.name + " | " + (link::is_request(t) ? "host → dev" : "dev → host") +
               " | " + m.body + " | " + m.reply + " |\n";
    }
    return out;
}

std::vector<std::string> message_layout_names() {
    std::vector<std::string> names;
    for (const Layout& l : kLayouts) names.push_back(l.name);
    return names;
}

std::string message_layout_markdown(const std::string& name) {
    std::string all;
    for (const Layout& l : kLayouts) {
        if (name == l.name) return l.markdown(l.name);
        all += std::string(all.empty() ? "" : ", ") + l.name;
    }
    throw std::invalid_argument("--layout: no message named '" + name + "'; one of " + all);
}

}  // namespace piezoloop::hostlink
