#include "json/json_reader.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <set>

#include "format/number.hpp"
#include "status_text.hpp"

namespace piezoloop::hostjson {

namespace {

const char* type_name(const nlohmann::json& j) {
    if (j.is_null()) return "null";
    if (j.is_boolean()) return "a boolean";
    if (j.is_number()) return "a number";
    if (j.is_string()) return "a string";
    if (j.is_array()) return "an array";
    return "an object";
}

// The library's message without its "[json.exception.x.n] " prefix.
std::string library_text(const std::exception& e) {
    std::string s = e.what();
    if (s.rfind("[json.exception.", 0) == 0) {
        const auto end = s.find("] ");
        if (end != std::string::npos) s.erase(0, end + 2);
    }
    return s;
}

// Follows the parser's events to know the path of the value being read,
// the keys each open object has, and the depth.
class PathTracker {
public:
    PathTracker(std::string source, int max_depth) : source_(std::move(source)), max_depth_(max_depth) {}

    bool event(int depth, nlohmann::json::parse_event_t ev, const nlohmann::json& parsed) {
        using E = nlohmann::json::parse_event_t;
        switch (ev) {
            case E::object_start:
            case E::array_start:
                if (depth >= max_depth_)  // depth counts from 0 at the top level
                    fail(value_path(), "nested deeper than " + std::to_string(max_depth_) + " levels");
                stack_.push_back({ev == E::object_start, value_path(), {}, {}, 0});
                break;
            case E::key: {
                Level& top = stack_.back();
                top.key = parsed.get<std::string>();
                if (!top.keys.insert(top.key).second) fail(value_path(), "duplicate key");
                break;
            }
            case E::object_end:
            case E::array_end:
                stack_.pop_back();
                next_element();
                break;
            case E::value:
                next_element();
                break;
        }
        return true;
    }

    // The path of the value the parser reads now (or just failed on).
    std::string value_path() const {
        if (stack_.empty()) return "";
        const Level& top = stack_.back();
        if (top.object) return top.path.empty() ? top.key : top.path + "." + top.key;
        return top.path + "[" + std::to_string(top.index) + "]";
    }

    [[noreturn]] void fail(const std::string& path, const std::string& message) const {
        throw JsonError((path.empty() ? source_ : path) + ": " + message);
    }

private:
    struct Level {
        bool object;
        std::string path;
        std::string key;             // object: the current key
        std::set<std::string> keys;  // object: the keys so far
        std::size_t index;           // array: the current element
    };
    void next_element() {
        if (!stack_.empty() && !stack_.back().object) ++stack_.back().index;
    }

    std::string source_;
    int max_depth_;
    std::vector<Level> stack_;
};

}  // namespace

nlohmann::json parse_text(const std::string& text, const std::string& source, const ParseLimits& limits) {
    if (text.size() > limits.max_bytes)
        throw JsonError(source + ": longer than " + std::to_string(limits.max_bytes) + " bytes");
    PathTracker tracker(source, limits.max_depth);
    try {
        return nlohmann::json::parse(
            text, [&](int depth, nlohmann::json::parse_event_t ev, nlohmann::json& parsed) {
                return tracker.event(depth, ev, parsed);
            });
    } catch (const nlohmann::json::out_of_range& e) {
        // 406: a number such as 1e309 that no double holds.
        tracker.fail(tracker.value_path(), "number out of the range of a double (" + library_text(e) + ")");
    } catch (const nlohmann::json::exception& e) {
        throw JsonError(source + ": not valid JSON: " + library_text(e));
    }
}

nlohmann::json read_file(const std::string& path, const ParseLimits& limits) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw JsonError(path + ": cannot open");
    std::string text(limits.max_bytes + 1, '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    if (in.bad()) throw JsonError(path + ": cannot read");
    text.resize(static_cast<std::size_t>(in.gcount()));
    if (text.size() > limits.max_bytes)
        throw JsonError(path + ": larger than " + std::to_string(limits.max_bytes) + " bytes");
    return parse_text(text, path, limits);
}

void Field::fail(const std::string& message) const {
    std::string text = path_.empty() ? std::string("(top level)") : path_;
    text += ": ";
    text += message;
    throw JsonError(text);
}

void Field::fail(const Status& s) const {
    std::string text = path_;
    if (!text.empty()) text += ".";
    text += describe(s);
    throw JsonError(text);
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
    if (it == j_->end()) return std::nullopt;
    // null is no value: an optional field is left out for its default.
    if (it->is_null()) Field(*it, child_path(key)).fail("must not be null (leave the field out for its default)");
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

size_t Field::size(size_t max) const {
    const size_t n = size();
    if (n > max) fail("at most " + std::to_string(max) + " elements (got " + std::to_string(n) + ")");
    return n;
}

void Field::only(std::initializer_list<const char*> allowed) const {
    only(std::vector<std::string>(allowed.begin(), allowed.end()));
}

void Field::only(const std::vector<std::string>& allowed) const {
    if (!j_->is_object()) fail(std::string("must be an object, not ") + type_name(*j_));
    for (auto it = j_->begin(); it != j_->end(); ++it) {
        bool known = false;
        for (const std::string& a : allowed) known = known || it.key() == a;
        if (!known) {
            std::string list;
            for (const std::string& a : allowed) {
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
    if (!(x >= lo && x <= hi)) fail("must be in [" + format::significant(lo) + ", " + format::significant(hi) + "]");
    return x;
}

double Field::number(const char* key, double fallback) const {
    const auto f = get(key);
    return f ? f->number() : fallback;
}

float Field::number_f32() const { return static_cast<float>(number_in_f32_range()); }

double Field::number_in_f32_range() const {
    const double x = number();
    if (!(std::fabs(x) <= static_cast<double>(std::numeric_limits<float>::max())))
        fail("must be within the range of a float (|x| <= " +
             format::significant(static_cast<double>(std::numeric_limits<float>::max())) + ")");
    return x;
}

int Field::integer(int lo, int hi) const { return static_cast<int>(integer64(lo, hi)); }

long long Field::integer64(long long lo, long long hi) const {
    if (!j_->is_number_integer() && !j_->is_number_unsigned())
        fail(std::string("must be an integer, not ") + type_name(*j_));
    if (j_->is_number_unsigned() && j_->get<unsigned long long>() > static_cast<unsigned long long>(hi))
        fail("must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    const long long x = j_->get<long long>();
    if (x < lo || x > hi) fail("must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return x;
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

std::size_t Field::enumeration_index(const char* const* names, std::size_t n) const {
    const std::string s = string();
    std::string list;
    for (std::size_t i = 0; i < n; ++i) {
        if (s == names[i]) return i;
        if (!list.empty()) list += "|";
        list += names[i];
    }
    fail("must be one of " + list + " (got \"" + s + "\")");
}

std::vector<double> Field::numbers() const { return numbers(std::numeric_limits<size_t>::max()); }

std::vector<double> Field::numbers(size_t max) const {
    const size_t n = size(max);
    std::vector<double> v;
    v.reserve(n);
    for (size_t i = 0; i < n; ++i) v.push_back(at(i).number());
    return v;
}

}  // namespace piezoloop::hostjson
