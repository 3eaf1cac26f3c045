// `piezoloop analyze loop`'s report (loop_report.hpp), moved out of the
// command so the Python module gives the same JSON.
#include "analysis/loop_report.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "analysis/hinf.hpp"
#include "analysis/margins.hpp"
#include "analysis/robust.hpp"
#include "lti/c2d.hpp"
#include "lti/lti_convert.hpp"
#include "numeric_constants.hpp"

namespace piezoloop::design {
namespace {

using nlohmann::json;

}  // namespace

json report_number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json report_hz(double w_rad_s) { return report_number(w_rad_s / kTwoPi); }

json roots_json(const std::vector<cplx>& r) {
    json a = json::array();
    for (const cplx& x : r) a.push_back({x.real(), x.imag()});
    return a;
}

json hinf_json(const HinfResult& h, bool loop_stable) {
    return {{"value", loop_stable ? report_number(h.norm) : json(nullptr)},
            {"peak", report_number(h.norm)},
            {"at_Hz", report_number(h.peak_Hz)},
            {"upper_bound", report_number(h.upper)},
            {"certified", h.certified}};
}

Zpk discretise_model(const Zpk& model, const LoopDiscretise& d, const std::string& what, const std::string& file,
                     bool is_plant) {
    Zpk m = model;
    if (d.rate_hz <= 0.0) return m;
    const double ts = 1.0 / d.rate_hz;
    if (is_discrete(m.ts)) {
        if (std::abs(m.ts - ts) > 1e-12 * ts)
            throw std::invalid_argument(what + ": " + file + " is discrete with ts = " +
                                        std::to_string(m.ts) + " s, not 1/rate-hz");
        m.ts = ts;
        return m;
    }
    const std::string& method = is_plant && !d.plant_method.empty() ? d.plant_method : d.method;
    return c2d(m, ts, parse_c2d_method(method), kTwoPi * d.prewarp_hz);
}

LoopReport loop_report(const LoopModels& a, const LoopReportOptions& o) {
    LoopReport rep;
    const Zpk p = discretise_model(a.plant, o.disc, "plant", a.plant_name, true);
    const Zpk k = discretise_model(a.controller, o.disc, "controller", a.controller_name);
    if (p.ts != k.ts)
        throw std::invalid_argument("controller: plant and controller must both be continuous or share ts "
                                    "(give --rate-hz to discretise continuous ones)");
    LoopAnalysisOptions opt;
    opt.phase_lag_at_Hz = o.phase_lag_hz;
    const LoopAnalysis r = analyze_loop(p, k, opt);
    const FeedbackLoop f = feedback_loop(zpk2ss(p), zpk2ss(k));
    const bool discrete = is_discrete(p.ts);

    json out;
    out["ts"] = p.ts;
    if (o.disc.rate_hz > 0.0)
        out["discretisation"] = {{"rate_Hz", o.disc.rate_hz}, {"method", o.disc.method},
                                 {"plant_method", o.disc.plant_method.empty() ? o.disc.method : o.disc.plant_method},
                                 {"prewarp_Hz", o.disc.prewarp_hz}};
    out["stable"] = r.stable;
    // Continuous: max Re(p) in rad/s. Discrete: the same measure of the
    // equivalent continuous pole, ln|z| / ts, and max |z| itself.
    out["poles_max_real"] = discrete ? report_number(std::log(r.stability_measure) / p.ts) : report_number(r.stability_measure);
    if (discrete) out["poles_max_abs"] = report_number(r.stability_measure);
    out["closed_loop_poles"] = roots_json(r.closed_loop_poles);
    auto norm = [&](const HinfResult& h) { return r.stable ? report_number(h.norm) : json(nullptr); };
    out["hinf_S"] = norm(r.hinf_S);
    out["hinf_T"] = norm(r.hinf_T);
    out["hinf_KS"] = norm(r.hinf_KS);
    out["hinf_GS"] = norm(r.hinf_GS);
    out["hinf"] = {{"S", hinf_json(r.hinf_S, r.stable)},
                   {"T", hinf_json(r.hinf_T, r.stable)},
                   {"KS", hinf_json(r.hinf_KS, r.stable)},
                   {"GS", hinf_json(r.hinf_GS, r.stable)}};
    out["hinf_WeS"] = nullptr;
    out["hinf_WyT"] = nullptr;
    std::optional<Zpk> we, wy, hm;
    if (a.we) {
        we = discretise_model(*a.we, o.disc, "we", a.we_name);
        const HinfResult h = weighted_hinf(*we, f.S);
        out["hinf_WeS"] = norm(h);
        out["hinf"]["WeS"] = hinf_json(h, r.stable);
    }
    if (a.wy) {
        wy = discretise_model(*a.wy, o.disc, "wy", a.wy_name);
        const HinfResult h = weighted_hinf(*wy, f.T);
        out["hinf_WyT"] = norm(h);
        out["hinf"]["WyT"] = hinf_json(h, r.stable);
    }
    if (we && wy)
        out["nominal_performance"] = r.stable && out["hinf_WeS"].get<double>() < 1.0 &&
                                     out["hinf_WyT"].get<double>() < 1.0;
    if (a.hm) {
        hm = discretise_model(*a.hm, o.disc, "hm", a.hm_name);
        const HinfResult h = weighted_hinf(*hm, f.T);
        json rs;
        rs["hinf_HmT"] = norm(h);
        rs["at_Hz"] = report_number(h.peak_Hz);
        rs["robustly_stable"] = r.stable && h.norm < 1.0;
        rs["meaning"] = "||H_m T||inf < 1: stable for every plant G (1 + Delta H_m), ||Delta||inf <= 1";
        out["hinf_HmT"] = norm(h);
        out["hinf"]["HmT"] = hinf_json(h, r.stable);
        if (o.family) {
            // The family perturbs the continuous plant's denominator: reload
            // the plant as given and discretise each member like the rest.
            const Zpk pc = a.plant;
            Tf tf = zpk2tf(pc);
            const int n = static_cast<int>(tf.den.size()) - 1;
            if (n < 1 || n > 8) {
                rs["family"] = {{"skipped", "the plant denominator needs 1 to 8 coefficients after the leading one"}};
            } else if (o.disc.rate_hz > 0.0 && !o.disc.plant_method.empty() && o.disc.plant_method != "tustin") {
                rs["family"] = {{"skipped", "the family discretises its members by Tustin; --plant-c2d differs"}};
            } else if (is_discrete(pc.ts) && o.disc.rate_hz > 0.0) {
                rs["family"] = {{"skipped", "the family is formed on a continuous plant"}};
            } else {
                const double ts = is_discrete(pc.ts) ? 0.0 : (o.disc.rate_hz > 0.0 ? 1.0 / o.disc.rate_hz : 0.0);
                const Zpk kc = ts > 0.0 ? a.controller : k;
                const Zpk hc = ts > 0.0 ? *a.hm : *hm;
                if (ts > 0.0 && (is_discrete(kc.ts) || is_discrete(hc.ts))) {
                    rs["family"] = {{"skipped", "with --rate-hz the family needs continuous controller and H_m"}};
                } else {
                    const FamilyResult fr = coefficient_family(tf, kc, hc, o.family_rel, ts);
                    auto member = [](const FamilyMember& m) {
                        return json{{"den_scale", m.scale},
                                    {"stable", m.stable},
                                    {"poles_max", report_number(m.stability_measure)},
                                    {"hinf_HmT", report_number(m.hinf_HmT)},
                                    {"coverage", report_number(m.coverage)}};
                    };
                    rs["family"] = {
                        {"relative_perturbation", o.family_rel},
                        {"method", ts > 0.0 ? "members discretised like the loop (Tustin)" : "continuous"},
                        {"count", fr.count},
                        {"unstable", fr.unstable},
                        {"all_stable", fr.unstable == 0},
                        {"worst_stability", member(fr.worst_stability)},
                        {"worst_hinf_HmT", member(fr.worst_hinf_HmT)},
                        {"worst_coverage", member(fr.worst_coverage)},
                        {"meaning",
                         "each of den[1..n] scaled by 1-rel, 1, 1+rel; poles_max: max real part (rad/s) or max |z|; "
                         "coverage: sup |G_i/G - 1| / |H_m| (<= 1: member inside the H_m set)"}};
                }
            }
        }
        out["robust_stability"] = rs;
    }
    out["bandwidth_hz"] = r.bandwidth_Hz ? json(*r.bandwidth_Hz) : json(nullptr);
    const Margins& m = r.margins;
    out["gain_margin_db"] = m.gain_margin ? report_number(m.gain_margin->gain_margin_db) : json(nullptr);
    out["gain_margin_at_hz"] = m.gain_margin ? report_hz(m.gain_margin->w_rad_s) : json(nullptr);
    out["phase_margin_deg"] = m.phase_margin ? report_number(m.phase_margin->phase_margin_deg) : json(nullptr);
    out["phase_margin_at_hz"] = m.phase_margin ? report_hz(m.phase_margin->w_rad_s) : json(nullptr);
    json pcs = json::array(), gcs = json::array();
    for (const auto& c : m.phase_crossovers)
        pcs.push_back({{"at_Hz", report_hz(c.w_rad_s)}, {"gain_margin_db", report_number(c.gain_margin_db)}});
    for (const auto& c : m.gain_crossovers)
        gcs.push_back({{"at_Hz", report_hz(c.w_rad_s)}, {"phase_margin_deg", report_number(c.phase_margin_deg)}});
    out["phase_crossovers"] = pcs;
    out["gain_crossovers"] = gcs;
    json lags = json::array();
    for (const auto& l : r.phase_lags)
        lags.push_back({{"at_Hz", l.f_Hz}, {"phase_lag_deg", l.lag_deg}, {"magnitude_db", l.magnitude_db}});
    out["phase_lag"] = lags;
    if (!r.stable) out["note"] = "closed loop unstable: hinf_* are null; hinf.*.peak is the sup on the frequency axis";
    rep.json = out;
    rep.plant = p;
    rep.controller = k;
    rep.we = we;
    rep.wy = wy;
    rep.hm = hm;
    rep.margins = r.margins;
    return rep;
}

}  // namespace piezoloop::design
