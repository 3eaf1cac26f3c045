// `piezoloop reproduce ahmad2020|janaideh2016|shan2012|all --out DIR`: every
// experiment of docs/models.md, 'Stages and scenarios', on the scenario files in configs/, as DIR/report.md
// with tables laid out like the sources' and PNG figures (tools/plot_sim.py).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "sim/experiments.hpp"
#include "sim/plotting.hpp"
#include "sim/report.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::cli {
namespace {

struct ReproduceArgs {
    std::string which;
    std::string out;
    std::string configs;
    int threads = 0;
    int substeps = 10;
    bool no_fidelity = false;
    bool no_plots = false;
};

int run(const ReproduceArgs& a) {
    const std::filesystem::path configs =
        a.configs.empty() ? sim::repository_root() / "configs" : std::filesystem::path(a.configs);
    std::vector<std::string> names;
    if (a.which == "all") names = {"ahmad2020", "janaideh2016", "shan2012"};
    else names = {a.which};
    std::vector<sim::Scenario> scenarios;
    for (const std::string& n : names) scenarios.push_back(sim::load_scenario(configs / (n + ".json")));

    const std::filesystem::path out(a.out);
    std::filesystem::create_directories(out / "figures");
    sim::ReproduceOptions o;
    o.threads = a.threads > 0 ? a.threads : std::max(1u, std::min(2u, std::thread::hardware_concurrency()));
    o.substeps = a.substeps;
    o.compare_fidelities = !a.no_fidelity;
    o.log = [](const std::string& m) { std::fprintf(stderr, "%s\n", m.c_str()); };

    const auto t0 = std::chrono::steady_clock::now();
    std::string body;
    std::vector<sim::ReportFigure> figures;
    nlohmann::json summary;
    for (const sim::Scenario& s : scenarios) {
        std::fprintf(stderr, "%s: %zu experiments\n", s.name.c_str(), s.experiments.size());
        const sim::ScenarioResult r = sim::run_scenario(s, o);
        body += sim::scenario_report(r, figures);
        summary[s.name] = {{"wall_s", r.wall_s}};
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    std::string md = "# piezoloop reproduce: the experiments of the sources\n\n";
    md += "Made by `piezoloop reproduce " + a.which + "` from the scenario files in configs/ (format: "
          "configs/scenarios.md; simulator: docs/simulator.md). Every figure is a closed-loop simulation of the "
          "control core (the code the boards run) against the simulated stage; tables are laid out like the "
          "sources' tables. Metrics (docs/models.md): hysteresis % at the input midpoint, e_max % = max |r − y| / range, "
          "e_rms % = rms(r − y) / range, all on the last (steady-state) period.\n\n";
    char line[160];
    std::snprintf(line, sizeof line, "Total wall time %.1f s on %d worker thread(s).\n\n", wall, o.threads);
    md += line;
    md += body;
    {
        std::ofstream f(out / "report.md");
        if (!f) throw std::runtime_error("--out: cannot write " + (out / "report.md").string());
        f << md;
    }
    nlohmann::json spec = nlohmann::json::array();
    for (const sim::ReportFigure& fig : figures) {
        nlohmann::json one = fig.spec;
        one["output"] = std::filesystem::absolute(out / fig.file).string();
        spec.push_back(one);
    }
    const std::filesystem::path spec_file = out / "figures.json";
    {
        std::ofstream f(spec_file);
        f << spec.dump();
    }
    if (!a.no_plots) {
        std::fprintf(stderr, "drawing %zu figures\n", figures.size());
        sim::run_plot_script("plot_sim.py", {spec_file.string()});
    }
    summary["report"] = (out / "report.md").string();
    summary["figures"] = figures.size();
    summary["wall_s"] = wall;
    std::printf("%s\n", summary.dump(1).c_str());
    return 0;
}

}  // namespace

void add_reproduce(CLI::App& app) {
    auto a = std::make_shared<ReproduceArgs>();
    CLI::App* cmd = app.add_subcommand(
        "reproduce", "Run every experiment of a source's scenario and write DIR/report.md with tables and figures");
    cmd->add_option("which", a->which, "ahmad2020 | janaideh2016 | shan2012 | all")
        ->required()
        ->check(CLI::IsMember({"ahmad2020", "janaideh2016", "shan2012", "all"}));
    cmd->add_option("--out", a->out, "output directory")->required();
    cmd->add_option("--configs", a->configs, "directory of the scenario files (default: the repository's configs/)");
    cmd->add_option("--threads", a->threads, "worker threads (default: up to 2)")->check(CLI::Range(1, 64));
    cmd->add_option("--substeps", a->substeps, "double fidelity: sub-steps per tick")->check(CLI::Range(1, 1000));
    cmd->add_flag("--no-fidelity", a->no_fidelity, "skip the float/double fidelity comparison");
    cmd->add_flag("--no-plots", a->no_plots, "write the report and figures.json, but do not draw");
    cmd->callback([a] {
        guarded([&] { return run(*a); });
    });
}

namespace {
const bool registered_reproduce = register_command(41, add_reproduce);
}  // namespace

}  // namespace piezoloop::cli
