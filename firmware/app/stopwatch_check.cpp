// Checks the board's stopwatch against code of known length: straight runs
// of N single-instruction NOPs, N = 0..kMaxNops, each measured kRepeats
// times at different phases. Prints one JSON line per N that is off by more
// than the stated resolution, then a summary:
//   {"board","stopwatch":"<unit>","resolution":r,"lengths":n,"samples":s,
//    "max_error":e,"mean_error_x100":m,"ok":true|false}
// and exits with 0 if every single measurement is within +-resolution.
// On hardware (cycles) the NOP count is not a cycle count (dual issue), so
// only the QEMU boards (instructions) run this check in CI.
#include <cstdint>
#include <utility>

#include "app/json_line.hpp"
#include "board_config.hpp"
#include "bsp/bsp.hpp"

namespace {

using piezoloop::fw::JsonLine;
namespace bsp = piezoloop::bsp;

constexpr int kMaxNops = 64;
constexpr int kRepeats = 16;

template <int N>
__attribute__((always_inline)) inline void nops() {
    if constexpr (N > 0) {
        asm volatile("nop");
        nops<N - 1>();
    }
}

template <int N>
uint32_t measure() {
    const uint32_t s = bsp::stopwatch_start();
    nops<N>();
    return bsp::stopwatch_elapsed(s);
}

// A small, varying amount of work between measurements shifts the phase of
// the next start relative to the timer's count edges.
volatile uint32_t g_sink = 0;
void shift_phase(int k) {
    for (int i = 0; i < k; ++i) g_sink = g_sink + 1u;
}

struct Result {
    int max_error = 0;
    int64_t sum_error = 0;
    int samples = 0;
    int bad_lengths = 0;
};

template <int N>
void check_length(Result& r) {
    int worst = 0;
    for (int k = 0; k < kRepeats; ++k) {
        shift_phase(k);
        const int err = static_cast<int>(measure<N>()) - N;
        r.sum_error += err;
        ++r.samples;
        const int a = err < 0 ? -err : err;
        if (a > worst) worst = a;
    }
    if (worst > r.max_error) r.max_error = worst;
    if (worst > static_cast<int>(bsp::config::kStopwatchResolution)) {
        ++r.bad_lengths;
        JsonLine j;
        j.str("board", bsp::kBoardName).uint("nops", N).sint("worst_error", worst).flush();
    }
}

template <int... Ns>
void check_all(Result& r, std::integer_sequence<int, Ns...>) {
    (check_length<Ns>(r), ...);
}

}  // namespace

int app_main() {
    Result r;
    check_all(r, std::make_integer_sequence<int, kMaxNops + 1>{});
    const int64_t mean_x100 = r.sum_error * 100 / r.samples;
    const bool ok = r.bad_lengths == 0;
    JsonLine j;
    j.str("board", bsp::kBoardName).str("stopwatch", bsp::config::kWorkUnit);
    j.uint("resolution", bsp::config::kStopwatchResolution).uint("lengths", kMaxNops + 1);
    j.uint("samples", static_cast<uint64_t>(r.samples)).sint("max_error", r.max_error);
    j.sint("mean_error_x100", mean_x100).boolean("ok", ok).flush();
    return ok ? 0 : 1;
}
