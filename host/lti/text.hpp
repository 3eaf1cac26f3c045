// Building the error messages of the design tools.
#pragma once

#include <cstdio>
#include <string>

namespace piezoloop::design {

// Message pieces appended one by one.
template <class... Parts>
std::string cat(const Parts&... parts) {
    std::string s;
    ((s += parts), ...);
    return s;
}

// A number with `significant` digits (%g): 6 for messages, 17 to round-trip.
inline std::string fmt(double v, int significant = 6) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.*g", significant, v);
    return buf;
}

}  // namespace piezoloop::design
