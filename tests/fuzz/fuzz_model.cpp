// libFuzzer target: arbitrary bytes as a model file (the JSON model format of
// docs/design.md: num/den, zeros/poles/gain, series) through the host's JSON
// reader and the model parser, as `design c2d --model F` reads it. Refusing
// the input with std::invalid_argument (a message naming the field) is the
// expected outcome; a crash, a sanitizer finding, any other exception, or a
// run past the libFuzzer timeout is a defect.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "json/json_reader.hpp"
#include "lti/model_json.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    try {
        const nlohmann::json j = piezoloop::hostjson::parse_text(text, "model");
        (void)piezoloop::design::parse_model(j, "model");
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
