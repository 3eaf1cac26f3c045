// Small helpers shared by the host-side tests.
#pragma once

#include <fstream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

namespace piezoloop::test {

// The message of the std::invalid_argument that f throws ("" if none).
template <class F>
std::string error_of(F f) {
    try {
        f();
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "";
}

// tests/golden/<name>.json, parsed.
inline nlohmann::json load_golden(const std::string& name) {
    std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/" + name + ".json");
    return nlohmann::json::parse(f);
}

}  // namespace piezoloop::test
