// The range checks of options that the command line and the Python module
// (python/src) both take: one implementation, called by both, so a value
// the command line refuses is refused by piezoloop.connect(...).record(...)
// too, with the same words. Each throws std::invalid_argument naming the
// option as the command line spells it ("--stall-s"; the Python argument is
// the same name with underscores) and the allowed range.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace piezoloop::options {

// Throws std::invalid_argument("<option>: <why>"), the form every refusal
// of an option (or of a field of a request) takes.
[[noreturn]] void refuse(const std::string& option, const std::string& why);

// lo <= v <= hi (NaN refused): "--stall-s: must be in [0.1, 3600] s (got nan)".
void require_in(const std::string& option, double v, double lo, double hi, const std::string& unit = "");

// `record`: --duration-s in [1e-6, 1e5] s, --decimation in [1, 2^24],
// --stall-s in [0.1, 3600] s.
void check_record_options(double duration_s, double decimation, double stall_s);

// `stream --prefill`: in [0, 32768] when given; the setpoints buffered
// before the tick starts, at most the board's FIFO (`capacity`); not given:
// the FIFO, or all `count` setpoints when fewer.
uint16_t stream_prefill(std::optional<double> prefill, std::size_t capacity, std::size_t count);

// A comma-separated list of numbers ("1,2.5,3"): every item a finite
// number (in T, double or float), none empty ("1,,2" is refused naming the
// item).
template <class T>
std::vector<T> parse_number_list(const std::string& option, const std::string& text);

}  // namespace piezoloop::options
