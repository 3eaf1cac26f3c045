// Replays a run recorded from servo.elf over the link (tests/firmware/
// check_servo.py) with the loop stepper `piezoloop sim --fidelity float`
// runs (common/piezoloop/loop_stepper.hpp, inside host/sim/loop_kernel.hpp),
// stepped here on its own rather than through the emulated stage:
// the board's pipeline setup, the reference controller, the reference stage
// as a StageModel of ideal parts, the wave check_servo.py sets, started the
// way the simulator starts (start_wave + arm before tick 0, stage at rest).
// Every recorded frame (r, y, e, u) must equal the simulator's bit for bit.
//
//   host_servo_replay float|q31 <frames.bin> <rate_Hz> <amplitude_um> <offset_um> <frequency_Hz> [profile.bin]
//
// With an emulation profile (check_servo.py --profile-test): the profile's
// stage, rate and full scales, and the controller check_servo.py sets there
// (limits +-10 V, 2e5 V/s; PID kp 0.5 V/um, ki 3000 V/(um s), cutoff 5 kHz,
// output +-10 V; no feedforward).
//
// frames.bin: frame-major raw 32-bit little-endian patterns, 4 per frame,
// from the wave's tick 0 on. Prints one line; exit status 0 if all equal.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "app/control_config.hpp"
#include "app/selftest_cases.hpp"
#include "piezoloop/emulated_stage.hpp"
#include "piezoloop/emulation_profile.hpp"
#include "piezoloop/loop_stepper.hpp"
#include "piezoloop/reference_stage.hpp"
#include "piezoloop/stage_model.hpp"

namespace {

using namespace piezoloop;

template <class T>
uint32_t bits(T v) {
    if constexpr (std::is_same_v<T, float>) return std::bit_cast<uint32_t>(v);
    else return static_cast<uint32_t>(v.raw());
}

template <class T>
int replay(const std::vector<uint32_t>& rec, float rate_Hz, float amplitude_um, float offset_um, float frequency_Hz,
           const EmulationProfile* profile) {
    PipelineSetup setup = fw::pipeline_setup(fw::kEmulatedAnalog, rate_Hz);
    StageConfig stage_config = ideal_stage(reference::plant(), rate_Hz);
    PipelineParams params = reference::params(true, true, false);
    if (profile != nullptr) {
        setup = fw::pipeline_setup(fw::BoardAnalog{fw::kEmulatedAnalog.hard, profile->position_full_scale_um,
                                                   profile->voltage_full_scale_V},
                                   static_cast<float>(profile->loop_rate_Hz));
        stage_config = profile->stage;
        params = PipelineParams{};
        params.limits = LimitsConfig{-10.0f, 10.0f, 2.0e5f, 0.0f};
        params.feedback = FeedbackKind::kPid;
        params.pid = PidConfig{0.5f, 3000.0f, 0.0f, 5000.0f, -10.0f, 10.0f};
    }
    auto pipe = std::make_unique<fw::FwPipeline<T>>(setup);
    if (!pipe->stage(params).ok()) return 2;
    TrajectoryConfig w{};
    w.waveform = Waveform::kSine;
    w.amplitude_um = amplitude_um;
    w.offset_um = offset_um;
    w.frequency_Hz = frequency_Hz;
    w.sample_rate_Hz = rate_Hz;
    w.return_fraction = 0.1f;
    w.duty = 0.5f;
    if (!pipe->start_wave(w).ok()) return 2;
    pipe->arm();
    StageModel stage;
    if (!stage.configure(stage_config).ok()) return 2;
    LoopStepper<T> loop(setup.position, setup.voltage, stage_config.sensor.gain);
    const std::size_t frames = rec.size() / 4;
    for (std::size_t k = 0; k < frames; ++k) {
        loop.tick(*pipe);
        loop.step(stage);
        const TickSignals<T>& s = pipe->last();
        const uint32_t want[4] = {bits(s.r), bits(s.y), bits(s.e), bits(s.u)};
        for (int c = 0; c < 4; ++c)
            if (rec[k * 4 + static_cast<std::size_t>(c)] != want[c]) {
                std::printf("{\"replay\":\"differs\",\"frame\":%zu,\"channel\":%d,\"board\":\"0x%08x\",\"sim\":\"0x%08x\"}\n",
                            k, c, rec[k * 4 + static_cast<std::size_t>(c)], want[c]);
                return 1;
            }
    }
    std::printf("{\"replay\":\"equal\",\"frames\":%zu}\n", frames);
    return frames > 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 7 && argc != 8) {
        std::fprintf(stderr, "usage: %s float|q31 frames.bin rate_Hz amplitude_um offset_um frequency_Hz\n", argv[0]);
        return 2;
    }
    std::FILE* f = std::fopen(argv[2], "rb");
    if (f == nullptr) return 2;
    std::vector<uint32_t> rec;
    uint8_t b[4];
    while (std::fread(b, 1, 4, f) == 4)
        rec.push_back(uint32_t{b[0]} | uint32_t{b[1]} << 8 | uint32_t{b[2]} << 16 | uint32_t{b[3]} << 24);
    std::fclose(f);
    const float rate = std::strtof(argv[3], nullptr), a = std::strtof(argv[4], nullptr),
                o = std::strtof(argv[5], nullptr), fr = std::strtof(argv[6], nullptr);
    EmulationProfile profile;
    if (argc == 8) {
        std::vector<uint8_t> blob(kEmulationProfileMaxBytes);
        std::FILE* pf = std::fopen(argv[7], "rb");
        if (pf == nullptr) return 2;
        blob.resize(std::fread(blob.data(), 1, blob.size(), pf));
        std::fclose(pf);
        if (const Status s = decode_profile(blob, profile); !s.ok()) {
            std::fprintf(stderr, "profile: %s: %s\n", s.field, s.message);
            return 2;
        }
    }
    const EmulationProfile* p = argc == 8 ? &profile : nullptr;
    if (std::strcmp(argv[1], "float") == 0) return replay<float>(rec, rate, a, o, fr, p);
    if (std::strcmp(argv[1], "q31") == 0) return replay<Q31>(rec, rate, a, o, fr, p);
    return 2;
}
