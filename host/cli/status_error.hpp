// Turns a core Status into the error text the command line prints:
// "<group>.<field>[<index>]: <message>".
#pragma once

#include <string>

#include "piezoloop/status.hpp"

namespace piezoloop::cli {

inline std::string describe(const Status& s) {
    std::string text = s.group ? std::string(s.group) + "." : std::string();
    text += s.field ? s.field : "?";
    if (s.index >= 0) text += "[" + std::to_string(s.index) + "]";
    return text + ": " + (s.message ? s.message : "invalid");
}

}  // namespace piezoloop::cli
