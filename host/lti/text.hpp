// Building the error messages of the design tools: pieces appended with
// cat(), numbers formatted by format::significant (host/format/number.hpp).
#pragma once

#include <string>

#include "format/number.hpp"

namespace piezoloop::design {

// Message pieces appended one by one.
template <class... Parts>
std::string cat(const Parts&... parts) {
    std::string s;
    ((s += parts), ...);
    return s;
}

}  // namespace piezoloop::design
