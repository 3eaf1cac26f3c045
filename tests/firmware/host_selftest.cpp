// Host replay of the firmware self-test (firmware/app/selftest_cases.hpp):
// the same pipeline type, the same emulated stage (StageModel, values passed
// as host/sim passes them), the same case setup and the same per-tick sequence
//   reading -> emulated_control_step (pipeline tick) -> command -> stage step
// as the board's 100 kHz interrupt, in a plain loop. Prints one JSON line
// per case through the firmware's own JSON writer, so the log fields are
// formatted by the same code as on the board:
//   {"board":"host","name","sample","ticks","frames","gaps","tracking_valid",
//    "e_max_um","e_rms_um","u_max_abs_V","log_hash"}
//   host_selftest float|q31
#include <array>
#include <cstdio>
#include <cstring>
#include <memory>
#include <span>

#include "app/control_config.hpp"
#include "app/json_line.hpp"
#include "app/selftest_cases.hpp"
#include "app/selftest_report.hpp"
#include "bsp/emulated_stage.hpp"

// The firmware's console, on the host: stdout.
namespace piezoloop::bsp {
void console_write(const char* text, std::size_t length) { std::fwrite(text, 1, length, stdout); }
}  // namespace piezoloop::bsp

namespace {

using namespace piezoloop;
using namespace piezoloop::fw;

template <class T>
int run_case(const SelfTestCase& c, const char* sample) {
    auto pipe = std::make_unique<FwPipeline<T>>(pipeline_setup(kEmulatedAnalog));
    auto stage = std::make_unique<EmulatedStage>();
    JsonLine j;
    j.str("board", "host").str("name", c.name);
    if (const Status s = prepare_case<T>(*pipe, *stage, c); !s.ok()) {
        j.str("error", s.field).str("message", s.message).flush();
        return 1;
    }
    LogAccumulator<T> acc(pipe->setup().position, pipe->setup().voltage);
    std::array<typename FwPipeline<T>::RecorderType::Frame, 64> frames;
    for (uint32_t k = 0; k < c.ticks; ++k) {
        emulated_control_step<T>(*pipe, *stage);
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

template <class T>
int run_all(const char* sample) {
    int failures = 0;
    for (const SelfTestCase& c : kSelfTestCases) failures += run_case<T>(c, sample);
    return failures;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc == 2 && std::strcmp(argv[1], "float") == 0) return run_all<float>("float");
    if (argc == 2 && std::strcmp(argv[1], "q31") == 0) return run_all<Q31>("q31");
    std::fprintf(stderr, "usage: %s float|q31\n", argv[0]);
    return 2;
}
