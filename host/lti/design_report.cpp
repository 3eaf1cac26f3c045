// `piezoloop design c2d`'s report (design_report.hpp), moved out of the
// command so the Python module builds the same JSON.
#include "lti/design_report.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "format/number.hpp"
#include "lti/c2d.hpp"
#include "lti/model_json.hpp"
#include "lti/realisation.hpp"
#include "lti/sos.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::design {
namespace {

using nlohmann::json;

void require(bool ok, const std::string& field, const std::string& what) {
    if (!ok) throw std::invalid_argument(field + ": " + what);
}

json sections_json(const std::vector<SosSection>& s) {
    json a = json::array();
    for (const SosSection& x : s) a.push_back({{"b0", x.b0}, {"b1", x.b1}, {"b2", x.b2}, {"a1", x.a1}, {"a2", x.a2}});
    return a;
}

}  // namespace

bool realise(const Zpk& discrete, const RealiseOptions& c, json& out) {
    const SampleFormat format = parse_sample_format(c.format);
    SosScaling sc;
    sc.norm = parse_sos_norm(c.scaling);
    sc.in_full_scale = c.in_full_scale;
    sc.out_full_scale = c.out_full_scale;
    sc.headroom = c.headroom;
    SosScalingReport rep;
    const std::vector<SosSection> sos = scale_sos(zpk2sos(discrete), sc, &rep);
    out["format"] = c.format;
    out["sections"] = sections_json(sos);
    out["scaling"] = {{"norm", sos_norm_name(sc.norm)},
                      {"in_full_scale", sc.in_full_scale},
                      {"out_full_scale", sc.out_full_scale},
                      {"headroom", sc.headroom},
                      {"partial_norms", rep.partial_norms},
                      {"output_may_saturate", rep.output_may_saturate},
                      {"order", "scipy zpk2sos 'nearest': poles nearest the unit circle last"}};
    std::vector<std::string> warnings;
    if (!std::isfinite(rep.partial_norms.back()))
        warnings.push_back("a pole on or outside the unit circle makes the cascade's norms infinite; nothing was "
                           "scaled (an integrator belongs in the core's PID block, not in a biquad)");
    else if (rep.output_may_saturate && format == SampleFormat::kQ31)  // float samples do not saturate
        warnings.push_back("the output's " + std::string(sos_norm_name(sc.norm)) + " norm times in/out full scale is " +
                           format::significant(rep.partial_norms.back()) +
                           " > 1: a full-scale input can saturate the output (raise out_full_scale)");
    bool fit = true;
    if (!c.no_check) {
        RealisationOptions o;
        o.format = format;
        o.in_full_scale = c.in_full_scale;
        o.out_full_scale = c.out_full_scale;
        const RealisationReport r = check_realisation(discrete, sos, o);
        out["realisation"] = to_json(r);
        fit = r.fit;
        for (const std::string& w : r.warnings) warnings.push_back(w);
    }
    out["warnings"] = warnings;
    return fit;
}

void check_realise_options(const RealiseOptions& c) {
    require(std::isfinite(c.rate_hz) && c.rate_hz > 0.0, "rate_hz", "must be finite and > 0");
    require(std::isfinite(c.in_full_scale) && c.in_full_scale > 0.0, "in_full_scale", "must be finite and > 0");
    require(std::isfinite(c.out_full_scale) && c.out_full_scale > 0.0, "out_full_scale", "must be finite and > 0");
    require(c.headroom > 0.0 && c.headroom <= 1.0, "headroom", "must be in (0, 1]");
}

C2dReport c2d_report(const Zpk& model, const std::string& model_file, double rate_hz, const std::string& method_name,
                     const std::optional<double>& prewarp_hz) {
    const double ts = 1.0 / rate_hz;
    json out;
    out["command"] = "c2d";
    out["model_file"] = model_file;
    out["rate_hz"] = rate_hz;
    Zpk discrete;
    if (is_discrete(model.ts)) {
        require(std::fabs(model.ts - ts) <= 1e-12 * ts, "model.ts",
                "the model is discrete with ts = " + format::significant(model.ts) + " s, not 1 / rate_hz = " + format::significant(ts) + " s");
        require(!prewarp_hz, "prewarp_hz", "the model is already discrete");
        out["method"] = "none (the model is already discrete at this rate)";
        discrete = model;
    } else {
        const C2dMethod method = parse_c2d_method(method_name);
        double prewarp = 0.0;
        if (prewarp_hz) {
            require(method == C2dMethod::kTustin, "prewarp_hz", "applies to --method tustin only");
            require(std::isfinite(*prewarp_hz) && *prewarp_hz > 0.0 && *prewarp_hz < 0.5 * rate_hz,
                    "prewarp_hz", "must be in (0, rate_hz / 2)");
            prewarp = kTwoPi * *prewarp_hz;
        }
        out["method"] = c2d_method_name(method);
        out["prewarp_hz"] = prewarp_hz ? *prewarp_hz : 0.0;
        out["continuous"] = to_json(model);
        discrete = c2d(model, ts, method, prewarp);
    }
    out["discrete"] = to_json(discrete);
    return {out, discrete};
}

}  // namespace piezoloop::design
