// One JSON object on one console line, keys in call order, built in a
// fixed buffer (bsp/text.hpp). Keys and string values are written as given:
// callers pass identifiers and plain ASCII without quotes or backslashes.
// A key may be given in up to three parts ({"plant_", unit, "_per_tick_max"}).
#pragma once

#include <cstdint>

#include "bsp/text.hpp"

namespace piezoloop::fw {

struct JsonKey {
    const char* a;
    const char* b = "";
    const char* c = "";
    JsonKey(const char* s) : a(s) {}  // NOLINT: implicit on purpose, j.uint("ticks", n)
    JsonKey(const char* s1, const char* s2, const char* s3 = "") : a(s1), b(s2), c(s3) {}
};

class JsonLine {
public:
    JsonLine() { line_.put('{'); }

    JsonLine& str(JsonKey key, const char* value) {
        k(key).line_.put('"').str(value == nullptr ? "" : value).put('"');
        return *this;
    }
    JsonLine& uint(JsonKey key, uint64_t value) {
        k(key).line_.udec(value);
        return *this;
    }
    JsonLine& sint(JsonKey key, int64_t value) {
        k(key).line_.dec(value);
        return *this;
    }
    JsonLine& fixed(JsonKey key, double value, int decimals) {
        k(key).line_.fixed(value, decimals);
        return *this;
    }
    JsonLine& boolean(JsonKey key, bool value) {
        k(key).line_.str(value ? "true" : "false");
        return *this;
    }
    // 64-bit value as a "0x%016x" string (JSON numbers are doubles).
    JsonLine& hex64(JsonKey key, uint64_t value) {
        k(key).line_.put('"').hex64(value).put('"');
        return *this;
    }

    // Writes the line and starts a new, empty object.
    void flush() {
        line_.put('}');
        line_.flush();
        line_.put('{');
        first_ = true;
    }

private:
    JsonLine& k(const JsonKey& key) {
        if (!first_) line_.put(',');
        first_ = false;
        line_.put('"').str(key.a).str(key.b).str(key.c).put('"').put(':');
        return *this;
    }

    bsp::TextLine line_;
    bool first_ = true;
};

}  // namespace piezoloop::fw
