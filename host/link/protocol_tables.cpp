#include "link/protocol_tables.hpp"

#include <cstdio>

#include "piezoloop/link/messages.hpp"

namespace piezoloop::hostlink {

std::string message_types_markdown() {
    std::string out = "| type | name | direction | body | reply |\n|---|---|---|---|---|\n";
    for (const link::MessageTypeDoc& m : link::kMessageTypes) {
        const uint8_t t = static_cast<uint8_t>(m.type);
        char id[8];
        std::snprintf(id, sizeof id, "0x%02X", static_cast<unsigned>(t));
        out += std::string("| ") + id + " | " + m.name + " | " + (link::is_request(t) ? "host → dev" : "dev → host") +
               " | " + m.body + " | " + m.reply + " |\n";
    }
    return out;
}

}  // namespace piezoloop::hostlink
