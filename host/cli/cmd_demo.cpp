// `piezoloop demo`: the reference stage (Janaideh2016's 15-operator PI
// hysteresis with a 1 kHz resonance) under four controller cases, on the
// same core that runs on the boards, with the metrics (docs/models.md) of each.
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "sim/metrics.hpp"
#include "sim/reference_loop.hpp"

namespace piezoloop::cli {
namespace {

struct DemoArgs {
    double frequency_Hz = 10.0;
    double amplitude_um = 15.0;
    double settle_periods = 2.0;
    std::string sample = "float";
    bool json = false;
};

struct Case {
    const char* name;
    PipelineParams params;
};

int run(const DemoArgs& a) {
    const Case cases[] = {
        {"open loop", reference::open_loop_params()},
        {"feedforward (inverse PI)", reference::params(true, false)},
        {"feedback (3 sections)", reference::params(false, true)},
        {"feedforward + feedback", reference::params(true, true)},
    };
    TrajectoryConfig wave;
    wave.waveform = Waveform::kTriangle;
    wave.amplitude_um = static_cast<float>(a.amplitude_um);
    wave.frequency_Hz = static_cast<float>(a.frequency_Hz);
    wave.sample_rate_Hz = reference::kRate_Hz;
    const int period = static_cast<int>(reference::kRate_Hz / a.frequency_Hz + 0.5);
    const int ticks = static_cast<int>((a.settle_periods + 1.0) * period);

    nlohmann::json out;
    out["stage"] = "Janaideh2016 15-operator PI model (+5 % linear, -10 % play weights) into a 1 kHz resonance";
    out["loop_rate_Hz"] = reference::kRate_Hz;
    out["sample"] = a.sample;
    out["trajectory"] = {{"waveform", "triangle"}, {"frequency_Hz", a.frequency_Hz},
                         {"amplitude_um", a.amplitude_um}};
    if (!a.json) {
        std::printf("piezoloop demo: reference stage (Janaideh2016 15-operator PI hysteresis with a\n"
                    "deliberate model error, 1 kHz resonance), %.0f kHz loop, %s core\n"
                    "%g Hz triangle, %g um peak-to-peak; figures over the last period\n\n",
                    reference::kRate_Hz / 1e3, a.sample.c_str(), a.frequency_Hz, 2.0 * a.amplitude_um);
        std::printf("%-26s %12s %9s %9s %10s %10s\n", "case", "hysteresis%", "e_max%", "e_rms%", "e_max_um",
                    "e_rms_um");
    }
    for (const Case& c : cases) {
        const sim::LoopLog log = a.sample == "q31"
                                     ? sim::run_reference_loop<Q31>(c.params, wave, ticks, period)
                                     : sim::run_reference_loop<float>(c.params, wave, ticks, period);
        const sim::TrackingMetrics m = sim::tracking_metrics(log.r_um, log.y_um);
        const double hyst = sim::hysteresis_pct(log.r_um, log.y_um);
        out["cases"].push_back({{"case", c.name}, {"hysteresis_pct", hyst}, {"e_max_pct", m.e_max_pct},
                                {"e_rms_pct", m.e_rms_pct}, {"e_max_um", m.e_max_um}, {"e_rms_um", m.e_rms_um}});
        if (!a.json)
            std::printf("%-26s %12.3f %9.3f %9.3f %10.4f %10.4f\n", c.name, hyst, m.e_max_pct, m.e_rms_pct,
                        m.e_max_um, m.e_rms_um);
    }
    if (a.json) std::cout << out.dump(1) << "\n";
    return 0;
}

}  // namespace

void add_demo(CLI::App& app) {
    auto args = std::make_shared<DemoArgs>();
    CLI::App* cmd = app.add_subcommand(
        "demo", "Closed-loop demonstration on the host: reference stage, four controller cases, tracking figures");
    cmd->add_option("--frequency-hz", args->frequency_Hz, "triangle frequency")
        ->check(CLI::Range(0.1, 200.0));
    cmd->add_option("--amplitude-um", args->amplitude_um, "triangle amplitude (peak)")
        ->check(CLI::Range(0.1, 30.0));
    cmd->add_option("--sample", args->sample, "core sample type")->check(CLI::IsMember({"float", "q31"}));
    cmd->add_flag("--json", args->json, "print JSON instead of a table");
    cmd->callback([args] { guarded([&] { return run(*args); }); });
}

namespace {
const bool registered_demo = register_command(90, add_demo);
}  // namespace

}  // namespace piezoloop::cli
