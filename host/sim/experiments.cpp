#include "sim/experiments.hpp"
#include "sim/f32.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

namespace piezoloop::sim {

namespace {

struct Job {
    size_t experiment = 0;  // index into experiments; SIZE_MAX: fidelity pair
    size_t cell = 0;
    const CaseSpec* c = nullptr;
    TrajectoryRequest request;
    Fidelity fidelity = Fidelity::kFloat;
    size_t log_points = 0;
    bool whole_run = false;
    double tone_Hz = 0.0;
};

constexpr size_t kFidelity = static_cast<size_t>(-1);

}  // namespace

RunOptions plan_run(double rate_Hz, const TrajectoryRequest& t, size_t log_points, bool whole_run) {
    RunOptions o;
    TrajectoryConfig& w = o.wave;
    w.sample_rate_Hz = f32(rate_Hz);
    w.waveform = t.waveform;
    if (t.waveform == Waveform::kSteps) {
        if (t.steps_um.empty() || !(t.hold_s > 0.0)) throw std::invalid_argument("steps: levels and hold_s needed");
        const auto [lo, hi] = std::minmax_element(t.steps_um.begin(), t.steps_um.end());
        const double mid = 0.5 * (*lo + *hi), half = std::max(0.5 * (*hi - *lo), 1e-9);
        o.table.clear();
        for (const double v : t.steps_um) o.table.push_back(f32((v - mid) / half));
        w.amplitude_um = f32(half);
        w.offset_um = f32(mid);
        w.frequency_Hz = f32(1.0 / (t.hold_s * static_cast<double>(t.steps_um.size())));
        w.cycles = 1;
        const uint64_t ticks = static_cast<uint64_t>(std::llround(rate_Hz * t.hold_s)) * t.steps_um.size();
        o.ticks = ticks;
        o.window_start = 0;
        o.window_midpoint_um = mid;
        o.log_start = 0;
        o.log_every = log_points == 0 ? 0 : std::max<uint64_t>(1, ticks / log_points);
        return o;
    }
    w.frequency_Hz = f32(t.frequency_Hz);
    w.amplitude_um = f32(0.5 * t.range_um);
    w.offset_um = t.midpoint_um ? f32(*t.midpoint_um) : t.unipolar ? f32(0.5 * t.range_um) : 0.0f;
    // Triangles start at their minimum at phase 0, sines at phase 3/4: the
    // stage starts at rest at the bottom of the range without a step.
    w.start_phase_cycles = t.waveform == Waveform::kSine ? 0.75f : 0.0f;
    const uint64_t period = std::max<uint64_t>(2, static_cast<uint64_t>(std::llround(rate_Hz / t.frequency_Hz)));
    uint64_t periods = static_cast<uint64_t>(std::max(1, t.periods));
    const double min_ticks = t.min_duration_s * rate_Hz;
    while (static_cast<double>(periods * period) < min_ticks) ++periods;
    o.ticks = periods * period;
    o.window_start = o.ticks - period;
    o.window_midpoint_um = w.offset_um;
    o.period_ticks = period;
    if (log_points > 0) {
        if (whole_run) {
            o.log_start = 0;
            o.log_every = std::max<uint64_t>(1, o.ticks / log_points);
        } else {
            o.log_start = o.window_start;
            o.log_every = std::max<uint64_t>(1, period / log_points);
        }
    }
    return o;
}

std::complex<double> tone_gain(const RunResult& r) {
    return std::abs(r.tone_r) > 0.0 ? r.tone_y / r.tone_r : std::complex<double>{};
}

ScenarioResult run_scenario(const Scenario& s, const ReproduceOptions& o) {
    ScenarioResult res;
    res.scenario = &s;
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<Job> jobs;
    res.experiments.resize(s.experiments.size());
    for (size_t e = 0; e < s.experiments.size(); ++e) {
        const ExperimentSpec& x = s.experiments[e];
        ExperimentResult& er = res.experiments[e];
        er.spec = &x;
        auto add = [&](const CaseSpec& c, TrajectoryRequest t, double amplitude_V, size_t points, bool whole,
                       double tone) {
            CellResult cell;
            cell.case_name = c.name;
            cell.case_label = c.label;
            cell.frequency_Hz = t.frequency_Hz;
            cell.range_um = t.range_um;
            cell.amplitude_V = amplitude_V;
            er.cells.push_back(cell);
            jobs.push_back(Job{e, er.cells.size() - 1, &c, t, Fidelity::kFloat, points, whole, tone});
        };
        for (const std::string& name : x.cases) {
            const CaseSpec& c = s.find_case(name);
            TrajectoryRequest t;
            t.waveform = x.waveform;
            t.unipolar = x.offset == "unipolar";
            t.periods = x.periods;
            t.min_duration_s = x.min_duration_s;
            if (x.kind == "loops") {
                t.frequency_Hz = x.frequencies_Hz.front();
                if (!x.amplitudes_V.empty()) {
                    for (const double v : x.amplitudes_V) {
                        t.range_um = v * s.nominal_um_per_V;
                        add(c, t, v, 1500, false, 0.0);
                    }
                } else {
                    for (const double a : x.amplitudes_um) {
                        t.range_um = a;
                        add(c, t, 0.0, 1500, false, 0.0);
                    }
                }
            } else if (x.kind == "tracking" || x.kind == "bode" || x.kind == "growth") {
                for (const double a : x.amplitudes_um)
                    for (const double f : x.frequencies_Hz) {
                        t.frequency_Hz = f;
                        t.range_um = a;
                        if (x.kind == "tracking") add(c, t, 0.0, 1500, false, 0.0);
                        else if (x.kind == "bode") add(c, t, 0.0, 0, false, f);
                        else add(c, t, 0.0, 6000, true, 0.0);
                    }
            } else {  // steps
                t.waveform = Waveform::kSteps;
                t.steps_um = x.steps_um;
                t.hold_s = x.hold_s;
                const auto [lo, hi] = std::minmax_element(x.steps_um.begin(), x.steps_um.end());
                t.range_um = *hi - *lo;
                t.frequency_Hz = 1.0 / (x.hold_s * static_cast<double>(x.steps_um.size()));
                add(c, t, 0.0, 6000, true, 0.0);
            }
        }
    }
    // Fidelity comparison: every case of a tracking experiment at its highest
    // frequency, and of a loops experiment at its largest amplitude.
    if (o.compare_fidelities) {
        for (const ExperimentResult& er : res.experiments) {
            const ExperimentSpec& x = *er.spec;
            if (x.kind != "tracking" && x.kind != "loops") continue;
            for (const std::string& name : x.cases) {
                const CellResult* best = nullptr;
                for (const CellResult& c : er.cells) {
                    if (c.case_name != name) continue;
                    if (!best || (x.kind == "tracking" ? c.frequency_Hz > best->frequency_Hz : c.range_um > best->range_um))
                        best = &c;
                }
                if (!best) continue;
                TrajectoryRequest t;
                t.waveform = x.waveform;
                t.unipolar = x.offset == "unipolar";
                t.periods = x.periods;
                t.min_duration_s = x.min_duration_s;
                t.frequency_Hz = best->frequency_Hz;
                t.range_um = best->range_um;
                for (const Fidelity f : {Fidelity::kFloat, Fidelity::kDouble}) {
                    CellResult cell = *best;
                    cell.fidelity = f;
                    res.fidelity_pairs.push_back(cell);
                    jobs.push_back(Job{kFidelity, res.fidelity_pairs.size() - 1, &s.find_case(name), t, f, 1500, false, 0.0});
                }
            }
        }
    }

    DahlCache dahl;
    std::atomic<size_t> next{0}, done{0};
    std::mutex log_mutex;
    auto worker = [&] {
        for (;;) {
            const size_t i = next.fetch_add(1);
            if (i >= jobs.size()) return;
            const Job& j = jobs[i];
            CellResult& cell = j.experiment == kFidelity ? res.fidelity_pairs[j.cell]
                                                         : res.experiments[j.experiment].cells[j.cell];
            try {
                BuildOptions bo;
                bo.reference_frequency_Hz = j.request.frequency_Hz;
                bo.substeps = o.substeps;
                bo.check_realisation = false;
                BuiltCase b = build_case(s, *j.c, bo, &dahl);
                RunOptions ro = plan_run(s.rate_Hz, j.request, j.log_points, j.whole_run);
                ro.fidelity = j.fidelity;
                ro.tone_Hz = j.tone_Hz;
                ro.hash = false;
                make_room_for_approach(b.model, ro);
                cell.run = run_loop(b.model, ro);
            } catch (const std::exception& e) {
                cell.error = e.what();
            }
            const size_t n = ++done;
            if (o.log && (n % 8 == 0 || n == jobs.size())) {
                std::lock_guard<std::mutex> lock(log_mutex);
                o.log(s.name + ": " + std::to_string(n) + "/" + std::to_string(jobs.size()) + " runs");
            }
        }
    };
    // Each case once more, with the realisation check, for the report.
    for (const Job& j : jobs) {
        if (res.built.count(j.c->name)) continue;
        try {
            BuildOptions bo;
            bo.reference_frequency_Hz = j.request.frequency_Hz;
            bo.substeps = o.substeps;
            res.built.emplace(j.c->name, build_case(s, *j.c, bo, &dahl));
        } catch (const std::exception&) {
            // reported by the runs themselves
        }
    }

    const int threads = std::max(1, o.threads);
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
    worker();
    for (std::thread& t : pool) t.join();
    res.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return res;
}

}  // namespace piezoloop::sim
