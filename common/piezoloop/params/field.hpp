// One field of a parameter group, as the group's declaration states it
// (params/groups.hpp): its name, unit, wire type, allowed range and whether
// it is limit-critical. Everything else -- the wire encoding, the field check
// with its error texts, the device's limit-critical policy, the host's JSON
// and the JSON Schema, the tables of docs/protocol.md -- is derived from the
// declarations by visitors, so a field is written down once.
//
// A visitor is any type with these members (X a scalar or enum member, A a
// std::array member, C its count member):
//   value(const Field&, X&)                  a scalar or enum field
//   begin(const char* name) / end()          a nested object ("pi", "pid")
//   count(const Field&, C&)                  the element count of the arrays
//                                            that follow (hidden in JSON)
//   values(const Field&, A&, C&, Travel)     an array of scalars
//   objects(const char*, A&, C&, Travel)     an array of described structs
//   text(const Field&, std::array<char, N>&) a zero-padded text field (link
//                                            messages only, not in groups)
// and groups are visited with describe(visitor, group). The link's message
// layouts (link/messages.hpp) are declared the same way.
#pragma once

#include <cstddef>
#include <cstdint>

namespace piezoloop::params {

// How a value travels in the link's little-endian layouts.
enum class Wire : uint8_t { kU8, kU16, kU32, kI16, kI32, kF32, kF64, kBool };

constexpr const char* wire_name(Wire w) {
    switch (w) {
        case Wire::kU8: return "u8";
        case Wire::kU16: return "u16";
        case Wire::kU32: return "u32";
        case Wire::kI16: return "i16";
        case Wire::kI32: return "i32";
        case Wire::kF32: return "f32";
        case Wire::kF64: return "f64";
        case Wire::kBool: return "bool";
    }
    return "?";
}

constexpr std::size_t wire_size(Wire w) {
    switch (w) {
        case Wire::kU8: case Wire::kBool: return 1;
        case Wire::kU16: case Wire::kI16: return 2;
        case Wire::kU32: case Wire::kI32: case Wire::kF32: return 4;
        case Wire::kF64: return 8;
    }
    return 0;
}

// Which elements of an array travel: only the first `count`, or all of them
// (a fixed layout, e.g. the four controller sections).
enum class Travel : uint8_t { kCount, kAll };

// The largest finite float32. Every number must be finite in the core's
// sample type, so f64 fields (SOS coefficients) are held to this too: a
// value finite in double but not in float would reach the core as infinity.
inline constexpr double kFloatMax = 3.4028234663852886e38;

struct Field {
    const char* name = "";
    const char* unit = "";  // "um", "V", "Hz", "s", "1" (dimensionless), ...
    const char* doc = "";
    Wire wire = Wire::kF32;
    double min = -kFloatMax;
    double max = kFloatMax;
    bool min_open = false;  // the bound itself is not allowed
    bool max_open = false;
    bool critical = false;  // limit-critical: changes only while disarmed
    const char* const* names = nullptr;  // enum: the name of each value
    uint8_t name_count = 0;

    constexpr bool is_enum() const { return names != nullptr; }
    constexpr bool is_number() const { return wire == Wire::kF32 || wire == Wire::kF64; }
    constexpr bool is_integer() const { return !is_enum() && !is_number() && wire != Wire::kBool; }

    constexpr Field range(double lo, double hi) const {
        Field f = *this;
        f.min = lo;
        f.max = hi;
        return f;
    }
    // (lo, hi], [lo, hi) or (lo, hi): a bound that is itself not allowed.
    constexpr Field open_min() const {
        Field f = *this;
        f.min_open = true;
        return f;
    }
    constexpr Field open_max() const {
        Field f = *this;
        f.max_open = true;
        return f;
    }
    constexpr Field limit_critical() const {
        Field f = *this;
        f.critical = true;
        return f;
    }
};

constexpr Field number(Wire w, const char* name, const char* unit, const char* doc) {
    Field f;
    f.name = name;
    f.unit = unit;
    f.doc = doc;
    f.wire = w;
    return f;
}
constexpr Field f32(const char* name, const char* unit, const char* doc) { return number(Wire::kF32, name, unit, doc); }
constexpr Field f64(const char* name, const char* unit, const char* doc) { return number(Wire::kF64, name, unit, doc); }

constexpr Field integer(Wire w, const char* name, const char* unit, const char* doc) {
    Field f = number(w, name, unit, doc);
    switch (w) {
        case Wire::kU8: f.min = 0; f.max = 255; break;
        case Wire::kU16: f.min = 0; f.max = 65535; break;
        case Wire::kU32: f.min = 0; f.max = 4294967295.0; break;
        case Wire::kI16: f.min = -32768.0; f.max = 32767.0; break;
        case Wire::kI32: f.min = -2147483648.0; f.max = 2147483647.0; break;
        default: break;
    }
    return f;
}
constexpr Field u8(const char* name, const char* doc) { return integer(Wire::kU8, name, "1", doc); }
constexpr Field u16(const char* name, const char* doc) { return integer(Wire::kU16, name, "1", doc); }
constexpr Field u32(const char* name, const char* unit, const char* doc) { return integer(Wire::kU32, name, unit, doc); }
constexpr Field i16(const char* name, const char* unit, const char* doc) { return integer(Wire::kI16, name, unit, doc); }
constexpr Field i32(const char* name, const char* unit, const char* doc) { return integer(Wire::kI32, name, unit, doc); }

// A zero-padded text field of a link message (visited by text()): its size
// is its array's.
constexpr Field text(const char* name, const char* doc) { return number(Wire::kU8, name, "", doc); }

constexpr Field boolean(const char* name, const char* doc) {
    Field f = number(Wire::kBool, name, "", doc);
    f.min = 0;
    f.max = 1;
    return f;
}

// An enum that travels as u8; its value is the index of its name.
template <std::size_t N>
constexpr Field enumeration(const char* name, const char* const (&names)[N], const char* doc) {
    static_assert(N >= 1 && N <= 255);
    Field f = number(Wire::kU8, name, "", doc);
    f.names = names;
    f.name_count = static_cast<uint8_t>(N);
    f.min = 0;
    f.max = static_cast<double>(N - 1);
    return f;
}

}  // namespace piezoloop::params
