// The link protocol's table of message types as a document, derived from
// its declaration (kMessageTypes in common/piezoloop/link/messages.hpp):
// the Markdown table of docs/protocol.md, section 2 (`piezoloop schema
// --messages`; a test fails when the committed table differs).
#pragma once

#include <string>

namespace piezoloop::hostlink {

// type (hex), name, direction, body, reply: one row per message type.
std::string message_types_markdown();

}  // namespace piezoloop::hostlink
