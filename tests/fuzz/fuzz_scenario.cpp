// libFuzzer target: arbitrary bytes as a scenario file (configs/scenarios.md)
// through the host's JSON reader and the scenario parser, as `piezoloop sim
// --scenario F` reads it (model files it names are looked up in an empty
// directory). Refusing the input with std::invalid_argument naming the
// field is the expected outcome; a crash, a sanitizer finding, any other
// exception, or a run past the libFuzzer timeout is a defect.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "json/json_reader.hpp"
#include "sim/scenario.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    try {
        const nlohmann::json j = piezoloop::hostjson::parse_text(text, "scenario");
        (void)piezoloop::sim::parse_scenario(j, "/nonexistent-piezoloop-fuzz");
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
