#include "measure/frf_report.hpp"

#include <cmath>

#include "format/number.hpp"

namespace piezoloop::measure {

using nlohmann::json;

namespace {

json pairs(const std::vector<cplx>& v) {
    json out = json::array();
    for (const cplx& x : v) out.push_back({x.real(), x.imag()});
    return out;
}

}  // namespace

json frf_report(const FrfRequest& a, const FrfRun& r, const json& source, std::optional<double> setpoint_um) {
    const FrfEstimate& e = r.estimate;
    json out;
    out["frequency_Hz"] = e.frequency_Hz;
    json std_db = json::array(), snr = json::array();
    for (std::size_t i = 0; i < e.response.size(); ++i) {
        std_db.push_back(std::isfinite(e.std_db[i]) ? json(e.std_db[i]) : json());
        snr.push_back(std::isfinite(e.snr_db[i]) ? json(e.snr_db[i]) : json());
    }
    out["response"] = pairs(e.response);
    out["std_db"] = std_db;
    out["snr_db"] = snr;
    if (!r.coherence.empty()) out["coherence"] = r.coherence;
    out["input"] = "u: command to the amplifier after the limiter (V)";
    out["output"] = "y: measured displacement, the sensor's reading / its gain (um)";
    out["units"] = {{"frequency", "Hz"}, {"response", "um/V"}, {"std_db", "dB (one standard deviation of |G|)"}};
    out["source"] = source;
    out["mode"] = a.closed ? "closed" : "open";
    if (!r.sensitivity.empty()) {
        out["sensitivity"] = pairs(r.sensitivity);
        out["complementary_sensitivity"] = pairs(r.complementary_sensitivity);
        out["units"]["sensitivity"] = "1: S = U / D at the plant input, T = 1 - S";
    }
    const MultisineLayout& l = r.plan.layout;
    out["excitation"] = {{"signal", a.signal},
                         {"point", "command"},        {"amplitude_V", a.amplitude_V},
                         {"bias_V", a.closed ? 0.0 : a.bias_V},
                         {"rate_Hz", l.rate_Hz},      {"period_samples", r.plan.period_samples},
                         {"periods", a.periods},      {"transient_periods", a.transient_periods}};
    if (a.signal == "multisine") {
        out["excitation"]["phases"] = "schroeder";
        out["excitation"]["first_bin"] = l.first_bin;
        out["excitation"]["last_bin"] = l.last_bin;
    } else {
        out["excitation"]["segment_samples"] = r.plan.segment_samples;
        out["excitation"]["segments"] = r.segments;
        if (a.signal == "sweep") out["excitation"]["law"] = "logarithmic, from_Hz to to_Hz over period_samples";
        else out["excitation"]["prbs"] = {{"order", r.plan.prbs_order}, {"hold_samples", r.plan.prbs_hold}};
    }
    if (setpoint_um) out["excitation"]["setpoint_um"] = *setpoint_um;
    out["method"] = a.signal == "multisine"
                        ? "per-period DFT at the excited bins, averaged over the periods; variance from the "
                          "period-to-period spread (Pintelon & Schoukens 2012, ch. 2)"
                        : "H1 = S_yu / S_uu, Welch: Hann-windowed half-overlapping segments; std_db from the "
                          "coherence (Bendat & Piersol 2010, table 9.6)";
    out["clipped_samples"] = r.clipped_samples;
    out["clipped_samples_transient"] = r.clipped_transient;
    out["limiter_trip"] = r.trip;
    out["warnings"] = r.warnings;
    out["log_hash"] = format::hex64(r.log_hash);
    out["wall_s"] = r.wall_s;
    return out;
}

}  // namespace piezoloop::measure
