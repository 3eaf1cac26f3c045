// The kernels of the tick, one sample per call as in a control tick, on the
// signals they see in the reference loop (reference_trace.hpp):
//  - biquad cascade, float (direct form II transposed) and Q31 (direct form I
//    with error feedback), 3 and 4 sections, fed the tracking error e:
//    ns per section per sample;
//  - the 15-operator PI bank (the inverse model of the reference stage),
//    PiOperator<float> and PiOperator<Q31>, fed the reference r: ns per sample;
//  - the Hammerstein plant step (float), fed the command u: ns per sample;
//  - the Dahl feedforward step, fed r: ns per sample, for the published
//    parameter set taken literally (a stiff model: every sample is split into
//    2^12 sub-steps, formed by 12 squarings) and rescaled so its loop is
//    visible (no squaring at these increments); see dahl.hpp.
// Each benchmark iteration times a batch of calls (batch_timer.hpp); the
// kernel's state restarts from rest at the start of each trace period,
// untimed, as in bench_pipeline.
//
// Run (see docs/benchmarks.md):
//   bench_kernels --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>
#include <vector>

#include "batch_timer.hpp"
#include "piezoloop/dahl.hpp"
#include "piezoloop/reference_stage.hpp"
#include "reference_trace.hpp"

using namespace piezoloop;

namespace {

// Samples per timed batch; divides the trace period.
constexpr std::size_t kBatch = 1000;
static_assert(bench::kTraceTicks % kBatch == 0);

// Replays `input` in timed batches of kBatch calls of step(x); reset() runs
// untimed at the start of every trace period. Returns ns per call.
template <class T, class Step, class Reset>
double replay(benchmark::State& state, const std::vector<T>& input, Step&& step, Reset&& reset) {
    bench::BatchTimer timer;
    std::size_t k = 0;
    for (auto _ : state) {
        if (k == 0) reset();
        const std::size_t begin = k, end = k + kBatch;
        timer.time(state, static_cast<int64_t>(kBatch), [&] {
            for (std::size_t i = begin; i < end; ++i) {
                auto y = step(input[i]);
                benchmark::DoNotOptimize(y);
            }
        });
        k = end == input.size() ? 0 : end;
    }
    return timer.ns_per_unit();
}

// The reference feedback (3 sections: near-integrator, notch on the 1 kHz
// resonance, 5 kHz low-pass) and, as a 4th section, a notch at 2.7 kHz with
// unit gain away from it, so the signal range stays the controller's.
std::array<SosSection, 4> kernel_sections() {
    std::array<SosSection, 4> s{};
    reference::feedback_sections(s.data());
    const double w = 2.0 * reference::kPi * 2.7e3;
    bench::require("notch", tustin(ContinuousSection{1.0, 2.0 * 0.05 * w, w * w, 1.0, 2.0 * 0.7 * w, w * w},
                                   reference::kRate_Hz, s[3]));
    return s;
}

template <class T>
void BM_Biquad(benchmark::State& state) {
    const int sections = static_cast<int>(state.range(0));
    const PipelineSetup setup = reference::setup();
    const std::vector<T> e = bench::as_samples<T>(bench::reference_trace().e_um, setup.position);
    const std::array<SosSection, 4> sos = kernel_sections();
    BiquadCascade<T, 4> cascade;
    bench::require("cascade", cascade.configure(sos.data(), sections, setup.position, setup.voltage));
    const double ns = replay(
        state, e, [&](T x) { return cascade.apply(x); }, [&] { cascade.reset(); });
    state.counters["ns_per_section_sample"] = ns / sections;
    state.counters["ns_per_sample"] = ns;
}

// The analytic inverse of the reference stage's 15-operator model: what the
// pipeline's feedforward runs.
PiModel inverse_model() {
    PiModel inv{};
    bench::require("invert_pi", invert_pi(reference::stage_model(), inv));
    return inv;
}

template <class T>
void BM_PiBank(benchmark::State& state) {
    const PipelineSetup setup = reference::setup();
    const std::vector<T> r = bench::as_samples<T>(bench::reference_trace().r_um, setup.position);
    const PiModel model = inverse_model();
    PiOperator<T> pi;
    bench::require("pi", pi.configure(model, setup.position, setup.voltage));
    const double ns = replay(
        state, r, [&](T x) { return pi.apply(x); }, [&] { pi.reset(); });
    state.counters["ns_per_sample"] = ns;
    state.counters["ns_per_operator"] = ns / model.count;
}

void BM_Plant(benchmark::State& state) {
    const std::vector<float>& u = bench::reference_trace().u_V;
    HammersteinPlant plant;
    bench::require("plant", plant.configure(reference::plant()));
    const double ns = replay(
        state, u, [&](float v) { return plant.step(v); }, [&] { plant.reset(); });
    state.counters["ns_per_sample"] = ns;
}

void BM_DahlFeedforward(benchmark::State& state, DahlParams params) {
    const std::vector<float>& r = bench::reference_trace().r_um;
    DahlFeedforward ff;
    bench::require("dahl", ff.configure(params));
    const double ns = replay(
        state, r, [&](float x) { return ff.step(x); }, [&] { ff.reset(r[0]); });
    state.counters["ns_per_sample"] = ns;
}

BENCHMARK(BM_Biquad<float>)->Name("biquad/float_df2t")->Arg(3)->Arg(4)->UseManualTime();
BENCHMARK(BM_Biquad<Q31>)->Name("biquad/q31_df1")->Arg(3)->Arg(4)->UseManualTime();
BENCHMARK(BM_PiBank<float>)->Name("pi_bank_15/float")->UseManualTime();
BENCHMARK(BM_PiBank<Q31>)->Name("pi_bank_15/q31")->UseManualTime();
BENCHMARK(BM_Plant)->Name("hammerstein_plant/float")->UseManualTime();
BENCHMARK_CAPTURE(BM_DahlFeedforward, literal, kAhmad2020Dahl)
    ->Name("dahl_feedforward/float/published_literal")
    ->UseManualTime();
BENCHMARK_CAPTURE(BM_DahlFeedforward, visible, dahl_params_in_units(kAhmad2020Dahl, 1e-5, 1.0))
    ->Name("dahl_feedforward/float/published_path_1e-5")
    ->UseManualTime();

}  // namespace

BENCHMARK_MAIN();
