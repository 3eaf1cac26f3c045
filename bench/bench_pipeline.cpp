// ns per tick of the reference pipeline (reference_stage.hpp): 15-operator
// inverse-PI feedforward + 6th-order feedback as 3 sections + repetitive
// control with N = 100 + limits + recorder (4 channels r, y, e, u, continuous,
// every tick), float and Q31, armed and fed with the closed-loop trace of
// reference_trace.hpp. Measured in the same run: the same tick written the
// straightforward way (straightforward_tick.hpp), whose outputs are first
// checked against the pipeline's on the same inputs; the two paired batch by
// batch for their ratio; and the pipeline paired with itself without one
// block, for what each block costs. Summary lines at the end.
//
// Run (see docs/benchmarks.md):
//   bench_pipeline --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "batch_timer.hpp"
#include "piezoloop/reference_stage.hpp"
#include "reference_pipeline.hpp"
#include "reference_trace.hpp"
#include "straightforward_tick.hpp"

using namespace piezoloop;

namespace {

// Ticks per timed batch. The recorder is drained between batches, so a batch
// must fit in its 1024 frames; 500 divides the trace period.
constexpr int kBatch = 500;
static_assert(bench::kTraceTicks % kBatch == 0);

using bench::Feed;
using bench::feed;
using bench::make_reference_pipeline;
using bench::RefPipeline;
using bench::restart;


// ---------------------------------------------------------------------------
// Sanity check (not timed): on the same inputs, over two trace periods with
// the restarts the benchmarks make, the straightforward tick and the Q31
// pipeline must agree with the float pipeline.
//
// Tolerances, in volts of the command (range ±10 V, |u| up to ~4.4 V here):
//  - straightforward vs pipeline float: 1e-3 V (measured: 5e-5 V). Both are
//    float, but the sections are realised differently (direct form I vs II
//    transposed), so rounding differs by an ulp or so per operation, and the
//    first section's near-integrator (pole at 1 - 6e-6, DC gain 374 V/µm)
//    sums those differences over a period. A wrong coefficient, sign, delay
//    index or operator order gives errors of 0.1 V and more within a period.
//  - Q31 vs float: 3e-3 V (measured: 8e-4 V; 2e-5 V with RC off). The RC's
//    inner loop (Q has unit DC gain) carries each period's rounding into the
//    next: u_rc differs by ~2e-6 µm between the two arithmetics, and the
//    near-integrator's 374 V/µm turns that into ~1e-3 V of u_fb.
constexpr double kStraightforwardTol_V = 1e-3;
constexpr double kQ31Tol_V = 3e-3;

struct Agreement {
    double straightforward_V = 0.0;
    double q31_V = 0.0;
    double max_u_V = 0.0;
};

Agreement check_agreement() {
    const Feed<float>& ff = feed<float>();
    const Feed<Q31>& fq = feed<Q31>();
    const SignalScale volt = reference::setup().voltage;
    auto pf = make_reference_pipeline<float>();
    auto pq = make_reference_pipeline<Q31>();
    bench::straightforward::Controller sf(reference::params(true, true, true), reference::setup());
    std::vector<RefPipeline<float>::RecorderType::Frame> frames(1024);
    std::vector<RefPipeline<Q31>::RecorderType::Frame> frames_q(1024);
    std::vector<bench::straightforward::Frame> frames_s(1024);
    Agreement a;
    for (int period = 0; period < 2; ++period) {
        for (int k = 0; k < bench::kTraceTicks; ++k) {
            float uf = 0.0f, us = 0.0f;
            Q31 uq{};
            if (k == 0) {
                uf = restart(*pf, ff);
                uq = restart(*pq, fq);
                sf.restart();
            } else {
                pf->set_setpoint(ff.r[static_cast<std::size_t>(k)]);
                uf = pf->tick(ff.y[static_cast<std::size_t>(k)]);
                pq->set_setpoint(fq.r[static_cast<std::size_t>(k)]);
                uq = pq->tick(fq.y[static_cast<std::size_t>(k)]);
            }
            us = sf.tick(ff.r[static_cast<std::size_t>(k)], ff.y[static_cast<std::size_t>(k)]);
            a.straightforward_V = std::max(a.straightforward_V, std::fabs(double{us} - uf));
            a.q31_V = std::max(a.q31_V, std::fabs(double{volt.to_physical(uq)} - uf));
            a.max_u_V = std::max(a.max_u_V, std::fabs(double{uf}));
            if (k % kBatch == kBatch - 1) {
                pf->recorder().read(frames);
                pq->recorder().read(frames_q);
                sf.drain(frames_s);
            }
        }
    }
    return a;
}

// ---------------------------------------------------------------------------
// Benchmarks. A runner owns one implementation of the tick and replays the
// trace through it: run() is the timed part (a batch of ticks, the tick
// inlined in its loop), restart() and drain() the untimed harness work. The
// same compiled run() serves the single and the paired benchmarks.

class TickRunner {
public:
    virtual ~TickRunner() = default;
    virtual void restart() = 0;                                   // start of a trace period
    virtual void run(std::size_t begin, std::size_t end) = 0;     // ticks [begin, end): timed
    virtual void drain() = 0;                                     // empty the recorder
    virtual const char* failure() const = 0;                      // nullptr when all went as configured
    virtual double frames_per_tick() const = 0;
};

// What runs in the tick. kReference is the reference pipeline; the others
// leave one block out, to see what it costs.
enum class Variant { kReference, kRecorderIdle, kNoRc, kNoFeedforward, kNoFeedback };

PipelineParams params_of(Variant v) {
    switch (v) {
        case Variant::kNoRc: return reference::params(true, true, false);
        case Variant::kNoFeedforward: return reference::params(false, true, true);
        case Variant::kNoFeedback: return reference::params(true, false, false);  // RC needs feedback
        case Variant::kReference:
        case Variant::kRecorderIdle: break;
    }
    return reference::params(true, true, true);
}

template <class T>
class PipelineRunner final : public TickRunner {
public:
    explicit PipelineRunner(Variant v)
        : record_(v != Variant::kRecorderIdle),
          f_(feed<T>()),
          pipe_(make_reference_pipeline<T>(record_, params_of(v))),
          frames_(RefPipeline<T>::RecorderType::capacity()) {}

    void restart() override {
        benchmark::DoNotOptimize(bench::restart(*pipe_, f_));
        ticks_ += bench::kRestartTicks;
    }
    void run(std::size_t begin, std::size_t end) override {
        for (std::size_t i = begin; i < end; ++i) {
            pipe_->set_setpoint(f_.r[i]);
            T u = pipe_->tick(f_.y[i]);
            benchmark::DoNotOptimize(u);
        }
        ticks_ += static_cast<int64_t>(end - begin);
    }
    void drain() override { recorded_ += static_cast<int64_t>(pipe_->recorder().read(frames_)); }
    const char* failure() const override {
        // Recording, every tick must have been stored: no overrun, still streaming.
        const auto& rec = pipe_->recorder();
        if (record_ && (rec.overruns() != 0 || recorded_ != ticks_ || rec.state() != RecorderState::kTriggered))
            return "recorder did not store every tick";
        if (!record_ && recorded_ != 0) return "idle recorder stored frames";
        if (!pipe_->armed()) return "pipeline not armed";
        return nullptr;
    }
    double frames_per_tick() const override {
        return ticks_ > 0 ? static_cast<double>(recorded_) / static_cast<double>(ticks_) : 0.0;
    }

private:
    bool record_;
    const Feed<T>& f_;
    std::unique_ptr<RefPipeline<T>> pipe_;
    std::vector<typename RefPipeline<T>::RecorderType::Frame> frames_;
    int64_t ticks_ = 0, recorded_ = 0;
};

class StraightforwardRunner final : public TickRunner {
public:
    StraightforwardRunner()
        : f_(feed<float>()), c_(reference::params(true, true, true), reference::setup()), frames_(1024) {}

    void restart() override {
        c_.restart();
        benchmark::DoNotOptimize(c_.tick(f_.r[0], f_.y[0]));
        ++ticks_;
    }
    void run(std::size_t begin, std::size_t end) override {
        for (std::size_t i = begin; i < end; ++i) {
            float u = c_.tick(f_.r[i], f_.y[i]);
            benchmark::DoNotOptimize(u);
        }
        ticks_ += static_cast<int64_t>(end - begin);
    }
    void drain() override { recorded_ += static_cast<int64_t>(c_.drain(frames_)); }
    const char* failure() const override {
        return c_.overruns != 0 || recorded_ != ticks_ ? "ring buffer did not store every tick" : nullptr;
    }
    double frames_per_tick() const override {
        return ticks_ > 0 ? static_cast<double>(recorded_) / static_cast<double>(ticks_) : 0.0;
    }

private:
    const Feed<float>& f_;
    bench::straightforward::Controller c_;
    std::vector<bench::straightforward::Frame> frames_;
    int64_t ticks_ = 0, recorded_ = 0;
};

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return *mid;
}

// The trace in batches: [begin, end) of the next batch after index k (k = 0:
// the trace restarts, its first sample belongs to the restart).
struct BatchCursor {
    std::size_t k = 0;
    template <class Restart>
    std::pair<std::size_t, std::size_t> next(Restart&& restart) {
        if (k == 0) {
            restart();
            k = 1;
        }
        const std::size_t begin = k;
        const std::size_t end = std::min<std::size_t>(k - k % kBatch + kBatch, bench::kTraceTicks);
        k = end == static_cast<std::size_t>(bench::kTraceTicks) ? 0 : end;
        return {begin, end};
    }
};

// One implementation: ns_per_tick is the median over batches (batch_timer.hpp).
void BM_Single(benchmark::State& state, TickRunner* (*make)()) {
    std::unique_ptr<TickRunner> r(make());
    bench::BatchTimer timer;
    BatchCursor cursor;
    for (auto _ : state) {
        const auto [begin, end] = cursor.next([&] { r->restart(); });
        timer.time(state, static_cast<int64_t>(end - begin), [&] { r->run(begin, end); });
        r->drain();
    }
    r->drain();
    if (const char* why = r->failure()) {
        state.SkipWithError(why);
        return;
    }
    state.counters["ns_per_tick"] = timer.ns_per_unit();
    state.counters["frames_per_tick"] = r->frames_per_tick();
}

// Two implementations on the same batch of the trace, one right after the
// other (alternating which goes first), so both see the same machine: the
// medians over batch pairs of the ratio b / a and of the difference a - b per
// tick are what a load or frequency change on a shared host leaves intact.
void BM_Paired(benchmark::State& state, TickRunner* (*make_a)(), TickRunner* (*make_b)()) {
    std::unique_ptr<TickRunner> a(make_a()), b(make_b());
    std::vector<double> ns_a, ns_b, ratio, diff;
    BatchCursor cursor;
    bool a_first = true;
    for (auto _ : state) {
        const auto [begin, end] = cursor.next([&] {
            a->restart();
            b->restart();
        });
        const double n = static_cast<double>(end - begin);
        auto timed = [&](TickRunner& r) {
            const auto t0 = std::chrono::steady_clock::now();
            r.run(begin, end);
            const auto t1 = std::chrono::steady_clock::now();
            return std::chrono::duration<double>(t1 - t0).count();
        };
        double sa = 0.0, sb = 0.0;
        if (a_first) {
            sa = timed(*a);
            sb = timed(*b);
        } else {
            sb = timed(*b);
            sa = timed(*a);
        }
        a_first = !a_first;
        state.SetIterationTime(sa + sb);
        ns_a.push_back(sa * 1e9 / n);
        ns_b.push_back(sb * 1e9 / n);
        ratio.push_back(sb / sa);
        diff.push_back((sa - sb) * 1e9 / n);
        a->drain();
        b->drain();
    }
    a->drain();
    b->drain();
    for (const TickRunner* r : {a.get(), b.get()}) {
        if (const char* why = r->failure()) {
            state.SkipWithError(why);
            return;
        }
    }
    state.counters["a_ns_per_tick"] = median(ns_a);
    state.counters["b_ns_per_tick"] = median(ns_b);
    state.counters["b_over_a"] = median(ratio);
    state.counters["a_minus_b_ns"] = median(diff);
}

template <class T, Variant V>
TickRunner* make_pipeline() {
    return new PipelineRunner<T>(V);
}
TickRunner* make_straightforward() { return new StraightforwardRunner(); }

void register_benchmarks() {
    using benchmark::RegisterBenchmark;
    RegisterBenchmark("pipeline_tick/float", BM_Single, make_pipeline<float, Variant::kReference>)
        ->UseManualTime();
    RegisterBenchmark("pipeline_tick/q31", BM_Single, make_pipeline<Q31, Variant::kReference>)->UseManualTime();
    RegisterBenchmark("straightforward_tick/float", BM_Single, make_straightforward)->UseManualTime();
    // a = the pipeline, b = the straightforward tick: b_over_a is the ratio.
    RegisterBenchmark("paired/pipeline_vs_straightforward/float", BM_Paired,
                      make_pipeline<float, Variant::kReference>, make_straightforward)
        ->UseManualTime();
    // a = the reference pipeline, b = without one block: a_minus_b_ns is
    // what the block costs in the tick.
    struct Named {
        const char* name;
        TickRunner* (*make_float)();
        TickRunner* (*make_q31)();
    };
    const Named blocks[] = {
        {"feedforward", make_pipeline<float, Variant::kNoFeedforward>, make_pipeline<Q31, Variant::kNoFeedforward>},
        {"rc", make_pipeline<float, Variant::kNoRc>, make_pipeline<Q31, Variant::kNoRc>},
        {"feedback_and_rc", make_pipeline<float, Variant::kNoFeedback>, make_pipeline<Q31, Variant::kNoFeedback>},
        {"recorder", make_pipeline<float, Variant::kRecorderIdle>, make_pipeline<Q31, Variant::kRecorderIdle>},
    };
    for (const Named& b : blocks) {
        RegisterBenchmark((std::string("block_cost/float/") + b.name).c_str(), BM_Paired,
                          make_pipeline<float, Variant::kReference>, b.make_float)
            ->UseManualTime();
        RegisterBenchmark((std::string("block_cost/q31/") + b.name).c_str(), BM_Paired,
                          make_pipeline<Q31, Variant::kReference>, b.make_q31)
            ->UseManualTime();
    }
}

// Console output as usual, plus the counters of every benchmark (the median
// over repetitions when there are several) for the summary.
class SummaryReporter : public benchmark::ConsoleReporter {
public:
    using benchmark::ConsoleReporter::ConsoleReporter;

    void ReportRuns(const std::vector<Run>& runs) override {
        for (const Run& run : runs) {
            if (run.error_occurred) continue;
            for (const auto& [counter, value] : run.counters) {
                const std::string key = run.run_name.function_name + " " + counter;
                if (run.run_type == Run::RT_Aggregate) {
                    if (run.aggregate_name == "median") median_[key] = value.value;
                } else {
                    samples_[key].push_back(value.value);
                }
            }
        }
        ConsoleReporter::ReportRuns(runs);
    }

    // Median of a counter over the repetitions of a benchmark; NaN if it did
    // not run.
    double get(const std::string& name, const std::string& counter) const {
        const std::string key = name + " " + counter;
        if (const auto m = median_.find(key); m != median_.end()) return m->second;
        const auto s = samples_.find(key);
        if (s == samples_.end() || s->second.empty()) return std::nan("");
        std::vector<double> v = s->second;
        std::sort(v.begin(), v.end());
        const std::size_t n = v.size();
        return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    }

private:
    std::map<std::string, double> median_;
    std::map<std::string, std::vector<double>> samples_;
};

}  // namespace

int main(int argc, char** argv) {
    register_benchmarks();
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;

    const Agreement a = check_agreement();
    std::printf(
        "sanity: max |u| %.3f V; max |u_straightforward - u_float| %.3g V (tolerance %.0e V); "
        "max |u_q31 - u_float| %.3g V (tolerance %.0e V)\n",
        a.max_u_V, a.straightforward_V, kStraightforwardTol_V, a.q31_V, kQ31Tol_V);
    if (!(a.straightforward_V <= kStraightforwardTol_V) || !(a.q31_V <= kQ31Tol_V)) {
        std::fprintf(stderr, "sanity check failed: the implementations do not compute the same tick\n");
        return 3;
    }

    int options = benchmark::ConsoleReporter::OO_Tabular;
    if (isatty(STDOUT_FILENO)) options |= benchmark::ConsoleReporter::OO_Color;
    SummaryReporter reporter(static_cast<benchmark::ConsoleReporter::OutputOptions>(options));
    benchmark::RunSpecifiedBenchmarks(&reporter);
    benchmark::Shutdown();

    const double ours = reporter.get("pipeline_tick/float", "ns_per_tick");
    const double q31 = reporter.get("pipeline_tick/q31", "ns_per_tick");
    const double plain = reporter.get("straightforward_tick/float", "ns_per_tick");
    std::printf("summary: median ns per tick: pipeline float %.2f, pipeline q31 %.2f, straightforward float %.2f\n",
                ours, q31, plain);
    const std::string paired = "paired/pipeline_vs_straightforward/float";
    std::printf("summary: paired (same batches): pipeline float %.2f ns, straightforward float %.2f ns, "
                "ratio straightforward / pipeline = %.2f\n",
                reporter.get(paired, "a_ns_per_tick"), reporter.get(paired, "b_ns_per_tick"),
                reporter.get(paired, "b_over_a"));
    for (const char* type : {"float", "q31"}) {
        std::printf("summary: %s block cost in the tick (ns, paired with/without):", type);
        for (const char* block : {"feedforward", "rc", "feedback_and_rc", "recorder"}) {
            std::printf(" %s %.2f", block,
                        reporter.get(std::string("block_cost/") + type + "/" + block, "a_minus_b_ns"));
        }
        std::printf("\n");
    }
    return 0;
}
