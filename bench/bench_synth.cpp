// Time of a mixed-sensitivity H∞ design (host/synth/mixsyn) on a 14-state
// augmented plant: the problem `order14` of tools/ref/synth_hinf.m (five
// lightly damped modes 300 Hz … 7 kHz, second-order W1, first-order W2 and
// W3), built here from the same numbers. Target: <= 0.5 s.
// Printed, never asserted (docs/benchmarks.md).
#include <cmath>
#include <numbers>
#include <optional>
#include <string>

#include <benchmark/benchmark.h>

#include "synth/mixsyn.hpp"

namespace {

using namespace piezoloop::design;

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// wn^2 / (s^2 + 2 zeta wn s + wn^2)
Zpk mode(double f_hz, double zeta) {
    const double wn = kTwoPi * f_hz, wd = wn * std::sqrt(1.0 - zeta * zeta);
    return Zpk{{}, {cplx(-zeta * wn, wd), cplx(-zeta * wn, -wd)}, wn * wn};
}

Zpk times(const Zpk& a, const Zpk& b) {
    Zpk r = a;
    r.zeros.insert(r.zeros.end(), b.zeros.begin(), b.zeros.end());
    r.poles.insert(r.poles.end(), b.poles.begin(), b.poles.end());
    r.gain *= b.gain;
    return r;
}

// (s/M + wb) / (s + wb A)
Zpk w1_std(double m, double wb, double a) { return Zpk{{cplx(-m * wb, 0)}, {cplx(-wb * a, 0)}, 1.0 / m}; }

void BM_Mixsyn14(benchmark::State& state) {
    const Zpk g = times(times(times(mode(300, 0.01), mode(1200, 0.005)), times(mode(2500, 0.02), mode(4000, 0.01))),
                        mode(7000, 0.03));
    const Zpk w1 = times(w1_std(std::sqrt(2.0), kTwoPi * 20, 1e-2), w1_std(std::sqrt(2.0), kTwoPi * 20, 1e-2));
    const Zpk w2{{cplx(-kTwoPi * 2000, 0)}, {cplx(-kTwoPi * 200000, 0)}, 100 * 0.05};
    const Zpk w3{{cplx(-kTwoPi * 800, 0)}, {cplx(-kTwoPi * 80000, 0)}, 100 * 0.3};
    const MixsynResult first = mixsyn(g, w1, w2, w3);  // the figures, outside the timed loop
    for (auto _ : state) {
        MixsynResult r = mixsyn(g, w1, w2, w3);
        benchmark::DoNotOptimize(r.gamma);
    }
    state.SetLabel("gamma " + std::to_string(first.gamma) + ", " + std::to_string(first.plant_order) +
                   " plant states, controller order " + std::to_string(first.order));
}
BENCHMARK(BM_Mixsyn14)->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
