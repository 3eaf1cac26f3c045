// A fixed closed-loop run of the reference pipeline on the reference stage,
// reduced to a 64-bit hash of every sample's bit pattern. The host build and
// each board run this same code; equal hashes prove the float path is
// bit-identical on x86-64 and Cortex-M7, and the Q31 path everywhere
// (docs/architecture.md, "Determinism").
#pragma once

#include <bit>
#include <cstdint>
#include <type_traits>

#include "piezoloop/loop_stepper.hpp"
#include "piezoloop/reference_stage.hpp"

namespace piezoloop::reference {

// FNV-1a, 64 bit: small, portable, and sensitive to every bit.
class LogHash {
public:
    void add(uint32_t word) {
        for (int i = 0; i < 4; ++i) {
            h_ ^= (word >> (8 * i)) & 0xffu;
            h_ *= 0x100000001b3ull;
        }
    }
    template <class T>
    void add_sample(T s) {
        if constexpr (std::is_same_v<T, float>) add(std::bit_cast<uint32_t>(s));
        else add(static_cast<uint32_t>(s.raw()));
    }
    uint64_t value() const { return h_; }

private:
    uint64_t h_ = 0xcbf29ce484222325ull;
};

struct RunResult {
    uint64_t log_hash = 0;  // over (r, y, u, RC output) of every tick
    uint32_t ticks = 0;
    float e_max_um = 0.0f;  // max |e| after the first 2000 ticks
};

// The pipeline is passed in (it is large: boards keep it in static storage).
// 10 Hz triangle, 15 µm amplitude, feedforward + feedback, stepped by the
// LoopStepper every closed loop uses (loop_stepper.hpp): one tick of compute
// delay, y converted to the sample type as an ADC would.
// The reference feedback crosses over near 150 Hz (the 1 kHz resonance sets
// that), so the closed loop's phase lag passes 90° far below the RC's Q
// cutoff: the RC condition |theta_T + theta_2| < 90° (docs/models.md, 'Repetitive control') fails and an RC
// with the published Q plugged into this loop would diverge (all_blocks_params()
// cuts Q off at 200 Hz, which is stable). So the RC runs beside the loop on
// its error, its output hashed but not applied: its arithmetic is still
// covered by the cross-platform hash.
template <class T, class PipelineT>
RunResult run_closed_loop(PipelineT& pipe, HammersteinPlant& plant, uint32_t ticks) {
    RunResult res;
    const PipelineParams p = params(true, true, false);
    RepetitiveController<T, 128> rc;
    if (!pipe.stage(p).ok() || !plant.configure(reference::plant()).ok() || !rc.configure(p.rc).ok())
        return res;
    TrajectoryConfig wave{};
    wave.waveform = Waveform::kTriangle;
    wave.amplitude_um = 15.0f;
    wave.frequency_Hz = 10.0f;
    wave.sample_rate_Hz = kRate_Hz;
    pipe.arm();
    if (!pipe.start_wave(wave).ok()) return res;
    const SignalScale pos = setup().position;
    LoopStepper<T> loop(pos, setup().voltage, 1.0f);  // the plant reads in µm
    LogHash hash;
    for (uint32_t k = 0; k < ticks; ++k) {
        const T y = loop.reading();
        const T u = loop.tick(pipe);
        hash.add_sample(pipe.last().r);
        hash.add_sample(y);
        hash.add_sample(u);
        hash.add_sample(rc.apply(pipe.last().e));
        const float e = pos.to_physical(pipe.last().e);
        if (k >= 2000 && (e > res.e_max_um || -e > res.e_max_um)) res.e_max_um = e < 0.0f ? -e : e;
        loop.step(plant);
    }
    res.log_hash = hash.value();
    res.ticks = ticks;
    return res;
}

inline constexpr uint32_t kHashTicks = 20000;  // 0.2 s: two periods of the 10 Hz wave

}  // namespace piezoloop::reference
