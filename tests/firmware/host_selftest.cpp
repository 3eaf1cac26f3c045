// Host replay of the firmware self-test (firmware/app/selftest_cases.hpp):
// the same pipeline type, the same emulated stage (common/piezoloop/
// emulated_stage.hpp: StageModel behind the loop stepper the simulator uses),
// the same case setup and the same per-tick sequence
//   reading -> pipeline tick -> command -> stage step
// as the board's 100 kHz interrupt, in a plain loop. Prints one JSON line
// per case through the firmware's own JSON writer, so the log fields are
// formatted by the same code as on the board:
//   {"board":"host","name","sample","ticks","frames","gaps","tracking_valid",
//    "e_max_um","e_rms_um","u_max_abs_V","log_hash"}
//   host_selftest float|q31 [CASE.bin ...]
// Then the multi-axis case with 1 .. kAxesCount axes (app/
// selftest_axes_cases.hpp: float 3, Q31 2), as the board runs it:
//   {"board":"host","name","sample","axes","loop_rate_Hz","ticks","frames",...,
//    "log_hash","e_max_um_<i>","e_rms_um_<i>","log_hash_<i>"}
// Board cases (common/piezoloop/board_case.hpp, written by `piezoloop sim
// --board-case`) given as files run after the reference cases, decoded and
// set up as the board does it (selftest_cases.hpp scenario_case /
// scenario_setup, the QEMU boards' hard limits).
#include <array>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <vector>
#include <span>
#include <type_traits>
#include <utility>

#include "app/control_config.hpp"
#include "app/json_line.hpp"
#include "app/selftest_axes_cases.hpp"
#include "app/selftest_cases.hpp"
#include "app/selftest_report.hpp"
#include "piezoloop/emulated_stage.hpp"

// The firmware's console, on the host: stdout.
namespace piezoloop::bsp {
void console_write(const char* text, std::size_t length) { std::fwrite(text, 1, length, stdout); }
}  // namespace piezoloop::bsp

namespace {

using namespace piezoloop;
using namespace piezoloop::fw;

template <class T>
int run_case(const SelfTestCase& c, const char* sample, const PipelineSetup& setup) {
    auto pipe = std::make_unique<FwPipeline<T>>(setup);
    auto stage = std::make_unique<EmulatedStage<T>>();
    JsonLine j;
    j.str("board", "host").str("name", c.name);
    if (const Status s = prepare_case<T>(*pipe, *stage, c); !s.ok()) {
        j.str("error", s.field).str("message", s.message).flush();
        return 1;
    }
    LogAccumulator<T> acc(pipe->setup().position, pipe->setup().voltage, c.metric_start_tick);
    std::array<typename FwPipeline<T>::RecorderType::Frame, 64> frames;
    for (uint32_t k = 0; k < c.ticks; ++k) {
        stage->tick(*pipe);
        stage->step();
        for (std::size_t n; (n = pipe->recorder().read(std::span(frames))) != 0;)
            for (std::size_t i = 0; i < n; ++i) acc.add(frames[i]);
    }
    j.str("sample", sample).uint("ticks", c.ticks);
    add_log_fields(j, c, acc);
    j.flush();
    std::fflush(stdout);
    return acc.frames() == c.ticks && acc.gaps() == 0 ? 0 : 1;
}

// The multi-axis case with N axes (app/selftest_axes_cases.hpp).
template <class T, int N>
int run_axes(const char* sample) {
    using Pipe = FwAxesPipeline<T, N>;
    auto pipe = std::make_unique<Pipe>(axes_setup<N>(kAxesRate_Hz<T>));
    auto stage = std::make_unique<EmulatedCoupledStage<T, N>>();
    JsonLine j;
    j.str("board", "host").str("name", kAxesCaseNames[N - 1]);
    auto stage_config = std::make_unique<CoupledStageConfig>();
    if (const Status s = prepare_axes_case<T, N>(*pipe, *stage, *stage_config); !s.ok()) {
        if (s.group != nullptr) j.str("group", s.group);
        j.str("error", s.field).str("message", s.message).flush();
        return 1;
    }
    auto log = std::make_unique<AxesLog<T, N>>(AxesLog<T, N>::make(*pipe));
    std::array<typename Pipe::AxisPipeline::RecorderType::Frame, 64> frames;
    constexpr uint32_t ticks = kAxesTicks<T>;
    for (uint32_t k = 0; k < ticks; ++k) {
        stage->tick(*pipe);
        stage->step();
        for (int a = 0; a < N; ++a)
            for (std::size_t n; (n = pipe->axis(a).recorder().read(std::span(frames))) != 0;)
                for (std::size_t i = 0; i < n; ++i) log->axis[static_cast<std::size_t>(a)].add(frames[i]);
    }
    j.str("sample", sample).uint("axes", N).uint("loop_rate_Hz", kAxesRateInt_Hz<T>).uint("ticks", ticks);
    add_axes_log_fields(j, *log);
    j.flush();
    std::fflush(stdout);
    return log->frames() == ticks && log->gaps() == 0 ? 0 : 1;
}

template <class T, int... I>
int run_axes_counts(const char* sample, std::integer_sequence<int, I...>) {
    int failures = 0;
    ((failures += run_axes<T, I + 1>(sample)), ...);
    return failures;
}

template <class T>
int run_board_case(const char* path, const char* sample) {
    std::ifstream f(path, std::ios::binary);
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    auto bc = std::make_unique<BoardCase>();
    const link::SampleFormat core = std::is_same_v<T, Q31> ? link::SampleFormat::kQ31 : link::SampleFormat::kFloat32;
    Status s = decode_board_case(bytes, *bc);
    if (s.ok() && bc->sample != core) s = error("sample", "the case was built for the other core");
    if (!s.ok()) {
        JsonLine j;
        j.str("board", "host").str("name", path).str("error", s.field).str("message", s.message).flush();
        return 1;
    }
    return run_case<T>(scenario_case(*bc), sample, scenario_setup(*bc, kEmulatedBoardHardLimits));
}

template <class T>
int run_all(const char* sample, int n_cases, char** cases) {
    int failures = 0;
    for (const SelfTestCase& c : kSelfTestCases) failures += run_case<T>(c, sample, pipeline_setup(kEmulatedAnalog));
    failures += run_axes_counts<T>(sample, std::make_integer_sequence<int, kAxesCount<T>>{});
    for (int i = 0; i < n_cases; ++i) failures += run_board_case<T>(cases[i], sample);
    return failures;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc >= 2 && std::strcmp(argv[1], "float") == 0) return run_all<float>("float", argc - 2, argv + 2);
    if (argc >= 2 && std::strcmp(argv[1], "q31") == 0) return run_all<Q31>("q31", argc - 2, argv + 2);
    std::fprintf(stderr, "usage: %s float|q31 [CASE.bin ...]\n", argv[0]);
    return 2;
}
