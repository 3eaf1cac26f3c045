#include "options/option_checks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <type_traits>

#include "format/number.hpp"

namespace piezoloop::options {

[[noreturn]] void refuse(const std::string& option, const std::string& why) {
    throw std::invalid_argument(option + ": " + why);
}

void require_in(const std::string& option, double v, double lo, double hi, const std::string& unit) {
    if (v >= lo && v <= hi) return;
    const std::string u = unit.empty() ? "" : " " + unit;
    throw std::invalid_argument(option + ": must be in [" + format::significant(lo, 10) + ", " +
                                format::significant(hi, 10) + "]" + u + " (got " + format::significant(v) + ")");
}

void check_record_options(double duration_s, double decimation, double stall_s) {
    require_in("--duration-s", duration_s, 1e-6, 1e5, "s");
    require_in("--decimation", decimation, 1, 1 << 24);
    if (decimation != std::floor(decimation)) throw std::invalid_argument("--decimation: must be a whole number");
    require_in("--stall-s", stall_s, 0.1, 3600.0, "s");
}

uint16_t stream_prefill(std::optional<double> prefill, std::size_t capacity, std::size_t count) {
    if (!prefill) return static_cast<uint16_t>(std::min(capacity, count));
    require_in("--prefill", *prefill, 0, 32768, "setpoints");
    if (*prefill != std::floor(*prefill)) throw std::invalid_argument("--prefill: must be a whole number");
    return static_cast<uint16_t>(std::min(static_cast<std::size_t>(*prefill), capacity));
}

template <class T>
std::vector<T> parse_number_list(const std::string& option, const std::string& text) {
    std::vector<T> out;
    std::size_t start = 0;
    for (int item = 1;; ++item) {
        const std::size_t comma = text.find(',', start);
        std::string cell = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
        cell.erase(0, cell.find_first_not_of(" \t"));
        cell.erase(cell.find_last_not_of(" \t") + 1);
        const std::string where = option + ": item " + std::to_string(item) + " of '" + text + "'";
        if (cell.empty()) throw std::invalid_argument(where + " is empty (give numbers as a,b,c)");
        char* end = nullptr;
        const T v = std::is_same_v<T, float> ? std::strtof(cell.c_str(), &end) : std::strtod(cell.c_str(), &end);
        if (end == cell.c_str() || *end != '\0') throw std::invalid_argument(where + " is not a number: " + cell);
        if (!std::isfinite(v)) throw std::invalid_argument(where + " must be a finite number (got " + cell + ")");
        out.push_back(v);
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    return out;
}

template std::vector<double> parse_number_list<double>(const std::string&, const std::string&);
template std::vector<float> parse_number_list<float>(const std::string&, const std::string&);

}  // namespace piezoloop::options
