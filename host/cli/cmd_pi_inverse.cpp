// `piezoloop pi-inverse`: the analytic inverse of a PI model (docs/models.md, 'Analytic PI inverse'), as
// JSON whose first entry is the threshold-0 (linear) term.
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "format/number.hpp"
#include "piezoloop/pi_inverse.hpp"
#include "status_text.hpp"

namespace piezoloop::cli {
namespace {

struct PiInverseArgs {
    std::vector<float> thresholds;
    std::vector<float> weights;
    float p0 = 0.0f;
    bool has_p0 = false;
};

// float printed with 7 significant digits (the precision a float carries),
// stored as the double nearest that decimal so the JSON reads naturally.
double decimal(float x) { return format::rounded(static_cast<double>(x), 7); }

int run(const PiInverseArgs& a) {
    if (a.thresholds.size() != a.weights.size()) {
        std::cerr << "error: weights: must have as many entries as thresholds ("
                  << a.thresholds.size() << "), got " << a.weights.size() << "\n";
        return kExitBadInput;
    }
    PiModel forward;
    Status s = pi_model_from_lists(a.thresholds.data(), a.weights.data(),
                                   static_cast<int>(a.thresholds.size()),
                                   a.has_p0 ? &a.p0 : nullptr, forward);
    PiModel inverse;
    if (s.ok()) s = invert_pi(forward, inverse);
    if (!s.ok()) {
        std::cerr << "error: " << describe(s) << "\n";
        return kExitBadInput;
    }
    nlohmann::json out;
    out["thresholds"] = {0.0};
    out["weights"] = {decimal(inverse.p0)};
    for (int j = 0; j < inverse.count; ++j) {
        out["thresholds"].push_back(decimal(inverse.thresholds[static_cast<unsigned>(j)]));
        out["weights"].push_back(decimal(inverse.weights[static_cast<unsigned>(j)]));
    }
    std::cout << out.dump() << "\n";
    return kExitOk;
}

}  // namespace

void add_pi_inverse(CLI::App& app) {
    auto args = std::make_shared<PiInverseArgs>();
    CLI::App* cmd = app.add_subcommand(
        "pi-inverse",
        "Analytic inverse of a Prandtl-Ishlinskii model (Janaideh2016). Without --p0 the first "
        "operator is the linear term (thresholds starting above zero are shifted down by r1).");
    add_number_list(cmd, "--thresholds", args->thresholds, "play thresholds r1,r2,... (ascending, >= 0)")->required();
    add_number_list(cmd, "--weights", args->weights, "weights p1,p2,... (one per threshold)")->required();
    cmd->add_option("--p0", args->p0, "weight of the linear term")
        ->each([args](const std::string&) { args->has_p0 = true; });
    cmd->callback([args] { guarded([&] { return run(*args); }); });
}

namespace {
const bool registered_pi_inverse = register_command(10, add_pi_inverse);
}  // namespace

}  // namespace piezoloop::cli
