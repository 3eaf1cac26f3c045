// Reading scenario files: a JSON value together with the path that names it,
// so every error says where it is, e.g.
//   "cases[2].controller.rc.k_rc: must be in (0, 2)".
#pragma once

#include <initializer_list>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "piezoloop/status.hpp"

namespace piezoloop::sim {

// Every scenario error: the message starts with the field path.
class ScenarioError : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

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
    bool is_string() const { return j_->is_string(); }
    bool has(const char* key) const { return j_->is_object() && j_->contains(key); }
    Field operator[](const char* key) const;         // required member of an object
    std::optional<Field> get(const char* key) const;  // optional member
    Field at(size_t i) const;                        // element of an array
    size_t size() const;                             // array length (must be an array)
    // Rejects members not in `allowed` (catches misspelt keys).
    void only(std::initializer_list<const char*> allowed) const;

    double number() const;
    // With a range check: lo <= x <= hi (inclusive ends), else "must be in [lo, hi]".
    double number_in(double lo, double hi) const;
    double number(const char* key, double fallback) const;
    int integer(int lo, int hi) const;
    bool boolean() const;
    std::string string() const;
    std::string string(const char* key, const std::string& fallback) const;
    // One of `choices`, else "must be one of a|b|c".
    std::string choice(std::initializer_list<const char*> choices) const;
    std::vector<double> numbers() const;  // array of numbers

private:
    const nlohmann::json* j_;
    std::string path_;
};

}  // namespace piezoloop::sim
