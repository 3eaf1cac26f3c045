// `piezoloop design`: from a continuous model (or a standard filter) to the
// biquad sections the core runs, with the realisation check (docs/models.md, 'Biquad cascades').
//
//   design c2d --model M.json --rate-hz F [--method tustin|zoh|matched]
//              [--prewarp-hz F] [--format float|q31] [scaling options]
//   design notch   --rate-hz F --frequency-hz f --depth-db d --width-hz w
//   design lowpass --rate-hz F --frequency-hz f [--q Q | --zeta z]
//   design leadlag --rate-hz F --zero-hz fz --pole-hz fp [--gain g]
//
// JSON on stdout: the continuous and discrete models, the sections
// (b0, b1, b2, a1, a2; a0 = 1) scaled for the format, the scaling report and
// the realisation check. Warnings also go to stderr. Bad input: "error:
// <field>: <what>" on stderr, exit code 2, nothing on stdout. With --strict
// an unfit realisation exits with code 1 (after printing the JSON).
#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "format/number.hpp"
#include "lti/c2d.hpp"
#include "lti/design_report.hpp"
#include "lti/filters.hpp"
#include "lti/model_json.hpp"
#include "lti/realisation.hpp"
#include "lti/sos.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::cli {
namespace {

using namespace piezoloop::design;
using nlohmann::json;

// Thrown for bad input; main path prints it and exits 2.
struct InputError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

// The realisation options (lti/design_report.hpp) and --strict.
struct Common : RealiseOptions {
    bool strict = false;
};

struct C2dArgs : Common {
    std::string model;
    std::string method = "tustin";
    std::optional<double> prewarp_hz;
};

// Warnings also go to stderr.
bool realise(const Zpk& discrete, const Common& c, json& out) {
    const bool fit = design::realise(discrete, c, out);
    for (const json& w : out["warnings"]) std::cerr << "warning: " << w.get<std::string>() << "\n";
    return fit;
}

struct NotchArgs : Common {
    double frequency_hz = 0.0, depth_db = 0.0, width_hz = 0.0;
};

struct LowpassArgs : Common {
    double frequency_hz = 0.0;
    std::optional<double> q, zeta;
};

struct LeadLagArgs : Common {
    double zero_hz = 0.0, pole_hz = 0.0, gain = 1.0;
};

void require(bool ok, const std::string& field, const std::string& what) {
    if (!ok) throw InputError(field + ": " + what);
}

void check_common(const Common& c) { check_realise_options(c); }

int finish(const json& out, bool fit, const Common& c) {
    std::cout << out.dump(1) << "\n";
    return (c.strict && !fit) ? kExitFailure : kExitOk;
}

int run_c2d(const C2dArgs& a) {
    check_common(a);
    C2dReport r = c2d_report(load_model_file(a.model), a.model, a.rate_hz, a.method, a.prewarp_hz);
    const bool fit = realise(r.discrete, a, r.json);
    return finish(r.json, fit, a);
}

int run_filter(const std::string& type, const Zpk& continuous, const Zpk& discrete, const json& params,
               const Common& c) {
    json out;
    out["command"] = type;
    out["filter"] = params;
    out["rate_hz"] = c.rate_hz;
    out["method"] = "tustin, pre-warped at the filter's frequency";
    out["continuous"] = to_json(continuous);
    out["discrete"] = to_json(discrete);
    const bool fit = realise(discrete, c, out);
    return finish(out, fit, c);
}

void add_common(CLI::App* cmd, Common& c) {
    cmd->add_option("--rate-hz", c.rate_hz, "loop rate (Hz)")->required();
    cmd->add_option("--format", c.format, "core sample type the sections are checked for")
        ->check(CLI::IsMember({"float", "q31"}));
    cmd->add_option("--scaling", c.scaling,
                    "per-section scaling of the partial cascades: l1 (no overflow for any full-scale input), "
                    "linf (sinusoids), none")
        ->check(CLI::IsMember({"l1", "linf", "none"}));
    cmd->add_option("--in-full-scale", c.in_full_scale, "physical input at Q31 full scale (default 1)");
    cmd->add_option("--out-full-scale", c.out_full_scale,
                    "physical output (and internal nodes) at Q31 full scale (default 1)");
    cmd->add_option("--headroom", c.headroom, "target norm of the internal nodes, (0, 1] (default 1)");
    cmd->add_flag("--strict", c.strict, "exit with code 1 if the realisation is unfit");
    cmd->add_flag("--no-check", c.no_check, "skip the realisation check");
}

void add_design(CLI::App& app) {
    CLI::App* design = app.add_subcommand(
        "design", "Controller and filter design: continuous model -> discrete -> biquad sections, with the "
                  "realisation check for the float or Q31 core");
    design->require_subcommand(1);

    auto c2d_args = std::make_shared<C2dArgs>();
    CLI::App* c2d_cmd = design->add_subcommand(
        "c2d", "Discretise a model file (JSON: num/den, zeros/poles/gain or series) and split it into sections");
    c2d_cmd->add_option("--model", c2d_args->model, "model file (JSON)")->required();
    c2d_cmd->add_option("--method", c2d_args->method, "tustin (default), zoh or matched")
        ->check(CLI::IsMember({"tustin", "zoh", "matched"}));
    c2d_cmd->add_option("--prewarp-hz", c2d_args->prewarp_hz, "Tustin pre-warp frequency (Hz)");
    add_common(c2d_cmd, *c2d_args);
    c2d_cmd->callback([c2d_args] { guarded([&] { return run_c2d(*c2d_args); }); });

    auto notch_args = std::make_shared<NotchArgs>();
    CLI::App* notch_cmd = design->add_subcommand("notch", "Notch filter from frequency, depth and -3 dB width");
    notch_cmd->add_option("--frequency-hz", notch_args->frequency_hz, "notch centre (Hz)")->required();
    notch_cmd->add_option("--depth-db", notch_args->depth_db, "gain at the centre (dB, < -3.01)")->required();
    notch_cmd->add_option("--width-hz", notch_args->width_hz, "distance between the -3 dB points (Hz)")->required();
    add_common(notch_cmd, *notch_args);
    notch_cmd->callback([notch_args] {
        guarded([&] {
            const NotchArgs& a = *notch_args;
            check_common(a);
            const NotchSpec s{a.frequency_hz, a.depth_db, a.width_hz};
            return run_filter("notch", notch_continuous(s), notch(s, a.rate_hz),
                              {{"frequency_hz", a.frequency_hz}, {"depth_db", a.depth_db}, {"width_hz", a.width_hz}},
                              a);
        });
    });

    auto lp_args = std::make_shared<LowpassArgs>();
    CLI::App* lp_cmd = design->add_subcommand("lowpass", "Second-order low-pass from corner frequency and Q (or zeta)");
    lp_cmd->add_option("--frequency-hz", lp_args->frequency_hz, "corner (natural) frequency (Hz)")->required();
    auto* q_opt = lp_cmd->add_option("--q", lp_args->q, "quality factor (default 0.7071, Butterworth)");
    auto* z_opt = lp_cmd->add_option("--zeta", lp_args->zeta, "damping ratio (= 1 / (2 Q))");
    q_opt->excludes(z_opt);
    add_common(lp_cmd, *lp_args);
    lp_cmd->callback([lp_args] {
        guarded([&] {
            const LowpassArgs& a = *lp_args;
            check_common(a);
            double q = 1.0 / std::numbers::sqrt2;
            if (a.q) q = *a.q;
            if (a.zeta) {
                require(std::isfinite(*a.zeta) && *a.zeta > 0.0, "zeta", "must be finite and > 0");
                q = 0.5 / *a.zeta;
            }
            const LowpassSpec s{a.frequency_hz, q};
            return run_filter("lowpass", lowpass_continuous(s), lowpass(s, a.rate_hz),
                              {{"frequency_hz", a.frequency_hz}, {"q", q}, {"zeta", 0.5 / q}}, a);
        });
    });

    auto ll_args = std::make_shared<LeadLagArgs>();
    CLI::App* ll_cmd = design->add_subcommand(
        "leadlag", "First-order lead (zero below pole) or lag (zero above pole) with DC gain");
    ll_cmd->add_option("--zero-hz", ll_args->zero_hz, "zero frequency (Hz)")->required();
    ll_cmd->add_option("--pole-hz", ll_args->pole_hz, "pole frequency (Hz)")->required();
    ll_cmd->add_option("--gain", ll_args->gain, "DC gain (default 1)");
    add_common(ll_cmd, *ll_args);
    ll_cmd->callback([ll_args] {
        guarded([&] {
            const LeadLagArgs& a = *ll_args;
            check_common(a);
            const LeadLagSpec s{a.zero_hz, a.pole_hz, a.gain};
            return run_filter("leadlag", leadlag_continuous(s), leadlag(s, a.rate_hz),
                              {{"zero_hz", a.zero_hz}, {"pole_hz", a.pole_hz}, {"gain", a.gain}}, a);
        });
    });
}

}  // namespace

namespace {
const bool registered_design = register_command(20, add_design);
}  // namespace

}  // namespace piezoloop::cli
