// Reading JSON input (scenario files, model files, parameter groups) with
// the path of every value, so each error says where it is, e.g.
//   "cases[2].controller.rc.k_rc: must be in (0, 2)".
// parse_text / read_file bound what a hostile file can cost (size, nesting
// depth) and refuse what JSON allows but a reader would silently resolve
// (duplicate keys) or cannot hold (numbers beyond a double); Field walks the
// result: objects with required and optional keys, unknown keys refused,
// numbers with a range, integers, booleans, names of an enumeration, arrays
// with a maximum size.
#pragma once

#include <cstddef>
#include <initializer_list>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "piezoloop/status.hpp"

namespace piezoloop::hostjson {

// Every input error: the message starts with the field path (or the file).
class JsonError : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

struct ParseLimits {
    std::size_t max_bytes = std::size_t{16} << 20;  // 16 MiB: far above any model or scenario
    int max_depth = 64;                             // objects and arrays within each other
};

// Parses JSON text; `source` (a file name, "--json") starts the messages of
// errors that have no field path yet. Throws JsonError for invalid JSON, a
// duplicate key, nesting deeper than limits.max_depth, a number beyond the
// range of a double, or text longer than limits.max_bytes.
nlohmann::json parse_text(const std::string& text, const std::string& source, const ParseLimits& limits = {});

// Reads and parses a file (at most limits.max_bytes are read, so a device
// such as /dev/zero costs nothing): JsonError "<path>: cannot open" etc.
nlohmann::json read_file(const std::string& path, const ParseLimits& limits = {});

// A JSON value and the path that names it.
class Field {
public:
    Field(const nlohmann::json& j, std::string path) : j_(&j), path_(std::move(path)) {}

    const std::string& path() const { return path_; }
    const nlohmann::json& json() const { return *j_; }
    std::string child_path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

    [[noreturn]] void fail(const std::string& message) const;
    // A core Status for this object: "<path>.<group>.<field>[i]: message".
    [[noreturn]] void fail(const Status& s) const;
    void check(const Status& s) const {
        if (!s.ok()) fail(s);
    }

    bool is_object() const { return j_->is_object(); }
    bool is_array() const { return j_->is_array(); }
    bool is_string() const { return j_->is_string(); }
    bool is_number() const { return j_->is_number(); }
    bool has(const char* key) const { return j_->is_object() && j_->contains(key); }
    Field operator[](const char* key) const;         // required member of an object
    std::optional<Field> get(const char* key) const;  // optional member (null refused: leave it out)
    Field at(size_t i) const;                        // element of an array
    size_t size() const;                             // array length (must be an array)
    size_t size(size_t max) const;                   // ... at most max, else "at most N elements"
    // Rejects members not in `allowed` (catches misspelt keys).
    void only(std::initializer_list<const char*> allowed) const;
    void only(const std::vector<std::string>& allowed) const;

    double number() const;  // finite
    // With a range check: lo <= x <= hi (inclusive ends), else "must be in [lo, hi]".
    double number_in(double lo, double hi) const;
    double number(const char* key, double fallback) const;
    // As a float (the boards' type): finite after the conversion too.
    float number_f32() const;
    // A double that is finite as a float too (|x| <= FLT_MAX), kept in double.
    double number_in_f32_range() const;
    int integer(int lo, int hi) const;
    long long integer64(long long lo, long long hi) const;
    bool boolean() const;
    std::string string() const;
    std::string string(const char* key, const std::string& fallback) const;
    // One of `choices`, else "must be one of a|b|c".
    std::string choice(std::initializer_list<const char*> choices) const;
    // The index of the name in `names` (an enumeration by name).
    template <std::size_t N>
    std::size_t enumeration(const char* const (&names)[N]) const {
        return enumeration_index(names, N);
    }
    std::size_t enumeration(const char* const* names, std::size_t n) const { return enumeration_index(names, n); }
    std::vector<double> numbers() const;             // array of finite numbers
    std::vector<double> numbers(size_t max) const;   // ... at most max of them

private:
    std::size_t enumeration_index(const char* const* names, std::size_t n) const;

    const nlohmann::json* j_;
    std::string path_;
};

}  // namespace piezoloop::hostjson
