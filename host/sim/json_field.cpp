#include "sim/json_field.hpp"

#include <cmath>
#include <sstream>

#include "status_text.hpp"

namespace piezoloop::sim {

namespace {

std::string fmt(double x) {
    std::ostringstream s;
    s << x;
    return s.str();
}

const char* type_name(const nlohmann::json& j) {
    if (j.is_null()) return "null";
    if (j.is_boolean()) return "a boolean";
    if (j.is_number()) return "a number";
    if (j.is_string()) return "a string";
    if (j.is_array()) return "an array";
    return "an object";
}

}  // namespace

void Field::fail(const std::string& message) const {
    std::string text = path_.empty() ? std::string("(top level)") : path_;
    text += ": ";
    text += message;
    throw ScenarioError(text);
}

void Field::fail(const Status& s) const {
    std::string text = path_;
    if (!text.empty()) text += ".";
    text += describe(s);
    throw ScenarioError(text);
}

Field Field::operator[](const char* key) const {
    if (!j_->is_object()) fail(std::string("must be an object, not ") + type_name(*j_));
    const auto it = j_->find(key);
    if (it == j_->end()) Field(*j_, child_path(key)).fail("required field is missing");
    return Field(*it, child_path(key));
}

std::optional<Field> Field::get(const char* key) const {
    if (!j_->is_object()) fail(std::string("must be an object, not ") + type_name(*j_));
    const auto it = j_->find(key);
    if (it == j_->end() || it->is_null()) return std::nullopt;
    return Field(*it, child_path(key));
}

Field Field::at(size_t i) const {
    if (!j_->is_array()) fail(std::string("must be an array, not ") + type_name(*j_));
    if (i >= j_->size()) fail("index out of range");
    return Field((*j_)[i], path_ + "[" + std::to_string(i) + "]");
}

size_t Field::size() const {
    if (!j_->is_array()) fail(std::string("must be an array, not ") + type_name(*j_));
    return j_->size();
}

void Field::only(std::initializer_list<const char*> allowed) const {
    if (!j_->is_object()) fail(std::string("must be an object, not ") + type_name(*j_));
    for (auto it = j_->begin(); it != j_->end(); ++it) {
        bool known = false;
        for (const char* a : allowed) known = known || it.key() == a;
        if (!known) {
            std::string list;
            for (const char* a : allowed) {
                if (!list.empty()) list += ", ";
                list += a;
            }
            Field(it.value(), child_path(it.key())).fail("unknown field (allowed here: " + list + ")");
        }
    }
}

double Field::number() const {
    if (!j_->is_number()) fail(std::string("must be a number, not ") + type_name(*j_));
    const double x = j_->get<double>();
    if (!std::isfinite(x)) fail("must be finite");
    return x;
}

double Field::number_in(double lo, double hi) const {
    const double x = number();
    if (!(x >= lo && x <= hi)) fail("must be in [" + fmt(lo) + ", " + fmt(hi) + "]");
    return x;
}

double Field::number(const char* key, double fallback) const {
    const auto f = get(key);
    return f ? f->number() : fallback;
}

int Field::integer(int lo, int hi) const {
    if (!j_->is_number_integer() && !j_->is_number_unsigned())
        fail(std::string("must be an integer, not ") + type_name(*j_));
    const long long x = j_->get<long long>();
    if (x < lo || x > hi) fail("must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return static_cast<int>(x);
}

bool Field::boolean() const {
    if (!j_->is_boolean()) fail(std::string("must be true or false, not ") + type_name(*j_));
    return j_->get<bool>();
}

std::string Field::string() const {
    if (!j_->is_string()) fail(std::string("must be a string, not ") + type_name(*j_));
    return j_->get<std::string>();
}

std::string Field::string(const char* key, const std::string& fallback) const {
    const auto f = get(key);
    return f ? f->string() : fallback;
}

std::string Field::choice(std::initializer_list<const char*> choices) const {
    const std::string s = string();
    std::string list;
    for (const char* c : choices) {
        if (s == c) return s;
        if (!list.empty()) list += "|";
        list += c;
    }
    fail("must be one of " + list + " (got \"" + s + "\")");
}

std::vector<double> Field::numbers() const {
    const size_t n = size();
    std::vector<double> v;
    v.reserve(n);
    for (size_t i = 0; i < n; ++i) v.push_back(at(i).number());
    return v;
}

}  // namespace piezoloop::sim
