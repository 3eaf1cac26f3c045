// The link protocol's tables as a document, derived from their declarations
// in common/piezoloop/link/messages.hpp: the table of message types
// (kMessageTypes; `piezoloop schema --messages`) and each message's layout
// (its describe(); `piezoloop schema --layout NAME`), as docs/protocol.md
// has them (a test fails when a committed table differs).
#pragma once

#include <string>
#include <vector>

namespace piezoloop::hostlink {

// type (hex), name, direction, body, reply: one row per message type.
std::string message_types_markdown();

// The messages whose layout is declared field by field, by name.
std::vector<std::string> message_layout_names();

// A message's layout: its size, then one row per field with its offset in
// the body, size, wire type, unit and meaning. Throws std::invalid_argument
// naming --layout for a name not in message_layout_names().
std::string message_layout_markdown(const std::string& name);

}  // namespace piezoloop::hostlink
