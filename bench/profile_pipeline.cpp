// Driver for instruction-level profiling of the reference tick (not a
// benchmark): runs the same ticks as bench_pipeline's pipeline_tick/<type>
// (or straightforward_tick/float), on the same inputs, with the ticks in one
// non-inlined function, tick_span(), so that a profiler can count exactly
// them:
//
//   valgrind --tool=callgrind --toggle-collect='*tick_span*' profile_pipeline float 10
//   callgrind_annotate --auto=yes callgrind.out.<pid>
//
// tick_span() calls the tick as the benchmark's loop does (GCC keeps
// Pipeline::tick out of line in both and inlines the blocks into it), so the
// per-source-line counts (build with -g) say what each block costs.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "reference_pipeline.hpp"
#include "straightforward_tick.hpp"

namespace {

template <class T>
[[gnu::noinline]] T tick_span(bench::RefPipeline<T>& pipe, const bench::Feed<T>& f, std::size_t begin,
                              std::size_t end) {
    T sink{};
    for (std::size_t i = begin; i < end; ++i) {
        pipe.set_setpoint(f.r[i]);
        sink = pipe.tick(f.y[i]);
        asm volatile("" : : "g"(&sink) : "memory");  // as benchmark::DoNotOptimize
    }
    return sink;
}

template <class T>
int run(int periods) {
    const bench::Feed<T>& f = bench::feed<T>();
    auto pipe = bench::make_reference_pipeline<T>();
    std::vector<typename bench::RefPipeline<T>::RecorderType::Frame> frames(1024);
    constexpr std::size_t kBatch = 500;
    long ticks = 0, recorded = 0;
    for (int p = 0; p < periods; ++p) {
        bench::restart(*pipe, f);
        ticks += bench::kRestartTicks;
        for (std::size_t k = 1; k < f.y.size();) {
            const std::size_t end = std::min(k - k % kBatch + kBatch, f.y.size());
            tick_span(*pipe, f, k, end);
            ticks += static_cast<long>(end - k);
            recorded += static_cast<long>(pipe->recorder().read(frames));
            k = end;
        }
    }
    std::printf("%ld ticks (%ld timed), %ld frames recorded, %u overruns\n", ticks,
                ticks - periods * bench::kRestartTicks, recorded, pipe->recorder().overruns());
    return recorded == ticks && pipe->recorder().overruns() == 0 ? 0 : 1;
}

[[gnu::noinline]] float tick_span(bench::straightforward::Controller& c, const bench::Feed<float>& f,
                                  std::size_t begin, std::size_t end) {
    float sink{};
    for (std::size_t i = begin; i < end; ++i) {
        sink = c.tick(f.r[i], f.y[i]);
        asm volatile("" : : "g"(&sink) : "memory");
    }
    return sink;
}

int run_straightforward(int periods) {
    const bench::Feed<float>& f = bench::feed<float>();
    bench::straightforward::Controller c(piezoloop::reference::params(true, true, true),
                                         piezoloop::reference::setup());
    std::vector<bench::straightforward::Frame> frames(1024);
    constexpr std::size_t kBatch = 500;
    long ticks = 0, recorded = 0;
    for (int p = 0; p < periods; ++p) {
        c.restart();
        c.tick(f.r[0], f.y[0]);
        ++ticks;
        for (std::size_t k = 1; k < f.y.size();) {
            const std::size_t end = std::min(k - k % kBatch + kBatch, f.y.size());
            tick_span(c, f, k, end);
            ticks += static_cast<long>(end - k);
            recorded += static_cast<long>(c.drain(frames));
            k = end;
        }
    }
    std::printf("%ld ticks (%ld timed), %ld frames recorded\n", ticks, ticks - periods, recorded);
    return recorded == ticks - periods ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
    const char* mode = argc > 1 ? argv[1] : "float";
    const int periods = argc > 2 ? std::atoi(argv[2]) : 10;
    if (std::strcmp(mode, "float") == 0) return run<float>(periods);
    if (std::strcmp(mode, "q31") == 0) return run<piezoloop::Q31>(periods);
    if (std::strcmp(mode, "straightforward") == 0) return run_straightforward(periods);
    std::fprintf(stderr, "usage: profile_pipeline [float|q31|straightforward] [periods]\n");
    return 2;
}
