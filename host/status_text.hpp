// Turns a core Status into the error text the host tools print:
// "<group>.<field>[<index>]: <message>".
#pragma once

#include <string>

#include "piezoloop/status.hpp"

namespace piezoloop {

inline std::string describe(const Status& s) {
    // Appended step by step: GCC 12 at -O3 reports a false -Wrestrict on
    // operator+ chains of std::string (GCC bug 105329).
    std::string text;
    if (s.group) {
        text += s.group;
        text += '.';
    }
    text += s.field ? s.field : "?";
    if (s.index >= 0) {
        text += '[';
        text += std::to_string(s.index);
        text += ']';
    }
    text += ": ";
    text += s.message ? s.message : "invalid";
    return text;
}

}  // namespace piezoloop
