// Simulated seconds per wall second of the simulator's reference closed loop,
// float fidelity, one core (target >= 200x real time):
//   100 kHz loop;
//   stage (common/piezoloop/stage_model.hpp): 16-bit DAC, amplifier with a
//     20 kHz bandwidth, Janaideh2016's 15-operator PI hysteresis (the
//     reference stage's, with its deliberate model error), a 9th-order plant
//     (Shan2012's stand-in of configs/shan2012.json: modes at 18, 28, 43,
//     65 kHz and an 80 kHz pole, five sections, Tustin here), a sensor with a
//     20 kHz bandwidth and seeded noise, 16-bit ADC;
//   full pipeline (common/piezoloop/pipeline.hpp): 1 kHz triangle
//     generator, 15-operator inverse-PI feedforward, PI feedback (Shan2012's
//     gains rescaled to this stage's 4.4 um/V), plug-in repetitive control
//     (N = 100, m1 = 3), output limits, recorder (r, y, e, u every tick);
//   one tick of compute delay: the very loop sim/loop_kernel.hpp runs for
//   `piezoloop sim` (included here from host/sim, core types only).
// Variants: with the log hash folded every tick (what `piezoloop sim`
// prints), and with the Q31 pipeline.
//
// The loop is a real, stable servo: after the benchmarks the summary prints
// its tracking error besides the speed (best of 10 runs of 1 s simulated, by
// the wall clock and by the thread's CPU time).
//
// Run: bench_sim [--benchmark_repetitions=5 --benchmark_report_aggregates_only=true]
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>

#include "../host/sim/loop_kernel.hpp"
#include "piezoloop/pi_inverse.hpp"
#include "piezoloop/reference_run.hpp"
#include "piezoloop/reference_stage.hpp"
#include "piezoloop/stage_model.hpp"
#include "piezoloop/tustin.hpp"

using namespace piezoloop;

namespace {

constexpr float kRate = 100000.0f;
constexpr double kPi = 3.14159265358979323846;

void require(const char* what, const Status& s) {
    if (!s.ok()) {
        std::fprintf(stderr, "bench_sim setup failed: %s: %s %s\n", what, s.field, s.message);
        std::exit(2);
    }
}

// A section with unit DC gain: poles (fp, zp), zeros (fz, zz) or none.
ContinuousSection mode(double fp, double zp, double fz = 0.0, double zz = 0.0) {
    const double wp = 2.0 * kPi * fp;
    if (fz == 0.0) return resonance(fp, zp);
    const double wz = 2.0 * kPi * fz, g = wp * wp / (wz * wz);
    return ContinuousSection{g, g * 2.0 * zz * wz, g * wz * wz, 1.0, 2.0 * zp * wp, wp * wp};
}

StageConfig stage_config() {
    StageConfig c{};
    c.rate_Hz = kRate;
    c.dac = ConverterConfig{16, -10.0f, 10.0f};
    c.amplifier = AmplifierConfig{1.0f, -10.0f, 10.0f, -10.0f, 10.0f, 20000.0f};
    c.plant.hysteresis = HysteresisKind::kPi;
    c.plant.pi = reference::true_stage_model();
    const ContinuousSection sections[5] = {mode(18e3, 0.5), mode(28e3, 0.03, 26e3, 0.02), mode(43e3, 0.04, 40e3, 0.03),
                                           mode(65e3, 0.1), first_order_lag(80e3)};
    c.plant.sections = 5;
    for (int i = 0; i < 5; ++i) require("plant", tustin(sections[i], kRate, c.plant.dynamics[static_cast<size_t>(i)]));
    c.sensor = SensorConfig{1.0f, 20000.0f, 0.003f, 7};
    c.adc = ConverterConfig{16, -60.0f, 60.0f};
    return c;
}

PipelineParams pipeline_params() {
    PipelineParams p{};
    p.feedforward = FeedforwardKind::kPiInverse;
    p.pi = reference::stage_model();
    p.feedback = FeedbackKind::kPid;
    // Shan2012's PI (Kp 1.3, Ki 4e4 on 0.3 V/um sensor volts, a 1 um/V
    // stage), rescaled to this stage's mean slope of 4.4 um/V.
    const float k = 0.3f / 4.4f;
    p.pid = PidConfig{1.3f * k, 40000.0f * k, 0.0f, 25000.0f, -10.0f, 10.0f};
    p.rc_enabled = true;
    p.rc = RepetitiveConfig{};
    p.rc.period_samples = 100;
    p.rc.m1 = 3;
    p.limits = LimitsConfig{-10.0f, 10.0f, 2.0e5f, 0.0f};
    return p;
}

template <class T>
struct Loop {
    using PipelineT = Pipeline<T, 128>;
    std::unique_ptr<PipelineT> pipe;
    StageModel stage;
    reference::LogHash hash;

    Loop() : pipe(std::make_unique<PipelineT>(reference::setup())) {
        typename PipelineT::RecorderType::Config rc{};
        rc.channels = {signal_index(SignalId::kR), signal_index(SignalId::kY), signal_index(SignalId::kE),
                       signal_index(SignalId::kU)};
        rc.mode = RecordMode::kContinuous;
        require("recorder", pipe->recorder().configure(rc));
        (void)pipe->recorder().arm();
        require("stage", stage.configure(stage_config()));
        require("pipeline", pipe->stage(pipeline_params()));
        TrajectoryConfig w{};
        w.waveform = Waveform::kTriangle;
        w.amplitude_um = 5.0f;
        w.frequency_Hz = 1000.0f;
        w.sample_rate_Hz = kRate;
        require("trajectory", pipe->start_wave(w));
        pipe->arm();
    }

    sim::LoopKernel<T, PipelineT, StageModel> hashed{*pipe, stage, 1.0f, &hash};
    sim::LoopKernel<T, PipelineT, StageModel> plain{*pipe, stage, 1.0f, nullptr};
    uint64_t k = 0;
    double sq = 0.0;

    template <bool kHash>
    void tick(uint64_t from) {
        auto observe = [&](const sim::TickView& v, const TickSignals<T>&, const StageModel&) {
            if (v.k >= from) {
                const double e = static_cast<double>(v.r_um) - v.y_um;
                sq += e * e;
            }
        };
        if constexpr (kHash) hashed.step(k++, observe); else plain.step(k++, observe);
    }

    // `ticks` more ticks; returns the RMS error over the last 100 (one period).
    template <bool kHash>
    double run(uint64_t ticks) {
        sq = 0.0;
        const uint64_t from = k + ticks - 100;
        for (uint64_t i = 0; i < ticks; ++i) tick<kHash>(from);
        return std::sqrt(sq / 100.0);
    }
};

// Two independent loops advanced tick by tick in one thread: a single loop
// is a chain of dependent float operations (each tick needs the previous
// reading), so a core has room for a second chain in flight. This is the
// throughput of one core when it simulates two runs, as reproduce does.
template <class T>
double run_pair(Loop<T>& a, Loop<T>& b, uint64_t ticks) {
    const uint64_t from = a.k + ticks - 100;
    a.sq = b.sq = 0.0;
    for (uint64_t i = 0; i < ticks; ++i) {
        a.template tick<false>(from);
        b.template tick<false>(from);
    }
    return std::sqrt(a.sq / 100.0);
}

constexpr uint64_t kChunk = 10000;  // 0.1 s simulated per iteration

template <class T, bool kHash>
void BM_SimLoop(benchmark::State& state) {
    Loop<T> loop;
    (void)loop.template run<kHash>(20000);  // settle: 0.2 s
    for (auto _ : state) benchmark::DoNotOptimize(loop.template run<kHash>(kChunk));
    const double ticks = static_cast<double>(state.iterations()) * static_cast<double>(kChunk);
    state.counters["ticks/s"] = benchmark::Counter(ticks, benchmark::Counter::kIsRate);
    state.counters["sim_s/s"] = benchmark::Counter(ticks / kRate, benchmark::Counter::kIsRate);
}

void BM_SimLoopPair(benchmark::State& state) {
    Loop<float> a, b;
    (void)run_pair(a, b, 20000);
    for (auto _ : state) benchmark::DoNotOptimize(run_pair(a, b, kChunk));
    const double ticks = 2.0 * static_cast<double>(state.iterations()) * static_cast<double>(kChunk);
    state.counters["ticks/s"] = benchmark::Counter(ticks, benchmark::Counter::kIsRate);
    state.counters["sim_s/s"] = benchmark::Counter(ticks / kRate, benchmark::Counter::kIsRate);
}

BENCHMARK(BM_SimLoopPair)->Name("SimLoop/float, two loops per thread")->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_SimLoop, float, false)->Name("SimLoop/float")->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_SimLoop, float, true)->Name("SimLoop/float+hash")->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_SimLoop, Q31, false)->Name("SimLoop/q31")->Unit(benchmark::kMillisecond);

// CPU time of this thread: on a shared machine the wall clock also counts
// the time the scheduler gives to others; the thread's CPU time does not.
double thread_cpu_s() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

constexpr int kReps = 10;

// Best of kReps runs of 1 s simulated: by the wall clock (returned) and by
// the thread's CPU time (cpu_factor).
template <class T, bool kHash>
double best_realtime_factor(double& e_rms_um, double& cpu_factor) {
    double best = 0.0;
    cpu_factor = 0.0;
    for (int rep = 0; rep < kReps; ++rep) {
        Loop<T> loop;
        const double c0 = thread_cpu_s();
        const auto t0 = std::chrono::steady_clock::now();
        e_rms_um = loop.template run<kHash>(static_cast<uint64_t>(kRate));  // 1 s simulated
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        best = std::max(best, 1.0 / wall);
        cpu_factor = std::max(cpu_factor, 1.0 / (thread_cpu_s() - c0));
    }
    return best;
}

}  // namespace

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    double e_float = 0.0, e_hash = 0.0, e_q31 = 0.0, fc = 0.0, fhc = 0.0, qc = 0.0;
    const double f = best_realtime_factor<float, false>(e_float, fc);
    const double fh = best_realtime_factor<float, true>(e_hash, fhc);
    const double q = best_realtime_factor<Q31, false>(e_q31, qc);
    double pair = 0.0;
    for (int rep = 0; rep < kReps; ++rep) {
        Loop<float> a, b;
        const auto t0 = std::chrono::steady_clock::now();
        (void)run_pair(a, b, static_cast<uint64_t>(kRate));
        pair = std::max(pair, 2.0 / std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::printf(
        "\nReference closed loop (100 kHz, 15-operator hysteresis, 9th-order plant, full pipeline), best of %d x 1 s,\n"
        "wall clock (thread CPU time):\n"
        "  float fidelity, float core:        %6.0f x real time (%5.1f ns per tick; target >= 200 x)  (cpu %4.0f x)\n"
        "  float fidelity, float core + hash: %6.0f x real time (%5.1f ns per tick)  (cpu %4.0f x)\n"
        "  float fidelity, Q31 core:          %6.0f x real time (%5.1f ns per tick)  (cpu %4.0f x)\n"
        "  float, two runs per thread:        %6.0f x real time in total (one core)\n"
        "  tracking of the 1 kHz, 10 um p-p triangle after 1 s: e_rms %.4f um (float), %.4f um (Q31)\n",
        kReps, f, 1e9 / (f * kRate), fc, fh, 1e9 / (fh * kRate), fhc, q, 1e9 / (q * kRate), qc, pair, e_float,
        e_q31);
    return 0;
}
