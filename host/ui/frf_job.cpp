#include "ui/frf_job.hpp"

#include <cmath>
#include <cstdio>

#include "format/number.hpp"
#include "lti/freqresp.hpp"
#include "measure/tf_fit.hpp"
#include "ui/form_number.hpp"

namespace piezoloop::ui {

using nlohmann::json;

namespace {

// The plan's option names and the form's fields ("--transient-periods"
// before "--periods": replaced whole).
constexpr std::pair<const char*, const char*> kOptionFields[] = {
    {"--transient-periods", "transient_periods"},
    {"--from-hz", "from_Hz"},
    {"--to-hz", "to_Hz"},
    {"--amplitude-v", "amplitude_V"},
    {"--bias-v", "bias_V"},
    {"--periods", "periods"},
    {"--signal", "signal"},
    {"--mode", "mode"},
    {"--restart-stage", "restart_stage"}};

// "N/M" (N poles, M zeros) or "N" (M = N - 1, as `identify tf --order`),
// or "" for no fit.
void parse_order(const std::string& text, int& poles, int& zeros) {
    poles = zeros = 0;
    if (text.empty()) return;
    int n = -1, m = -1;
    char tail = 0;
    const int got = std::sscanf(text.c_str(), "%d/%d%c", &n, &m, &tail);
    if (got == 1 && text.find('/') == std::string::npos && std::sscanf(text.c_str(), "%d%c", &n, &tail) == 1) m = n - 1;
    else if (got != 2) n = -1;
    if (n < 1 || n > 20 || m < 0 || m > n)
        throw FieldRefusal("fit_order", "fit_order: must be N/M, N poles (1 to 20) and M zeros (0 to N), e.g. 4/2, "
                                        "or empty for no fit");
    poles = n;
    zeros = m;
}

json finite_or_null(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

}  // namespace

std::vector<double> unwrapped_phase_deg(const std::vector<std::complex<double>>& g) {
    std::vector<double> out;
    double turn = 0.0;
    for (std::size_t i = 0; i < g.size(); ++i) {
        const double p = design::phase_deg(g[i]);
        if (i > 0) {
            const double prev = out.back() - turn;
            if (p - prev > 180.0) turn -= 360.0;
            else if (p - prev < -180.0) turn += 360.0;
        }
        out.push_back(p + turn);
    }
    return out;
}

namespace {

json fit_json(const FrfForm& f, const measure::FrfEstimate& e, double rate_Hz) {
    json out = {{"order", std::to_string(f.fit_poles) + "/" + std::to_string(f.fit_zeros)}};
    // 1 / variance weights from the per-line standard deviation in dB, as `identify tf`.
    std::vector<double> var;
    const double rel_per_db = std::log(10.0) / 20.0;
    for (std::size_t i = 0; i < e.std_db.size(); ++i) var.push_back(std::pow(e.std_db[i] * rel_per_db * std::abs(e.response[i]), 2));
    measure::TfFitOptions o;
    o.poles = f.fit_poles;
    o.zeros = f.fit_zeros;
    o.ts = 1.0 / rate_Hz;
    try {
        const measure::TfFit fit = measure::fit_tf(e.frequency_Hz, e.response, var, o);
        const std::vector<design::cplx> g = measure::tf_fit_response(fit, e.frequency_Hz);
        json mag = json::array();
        for (const design::cplx x : g) mag.push_back(design::magnitude_db(x));
        out["magnitude_dB"] = mag;
        out["phase_deg"] = unwrapped_phase_deg(g);
        out["weighted_rms"] = fit.weighted_rms;
        out["iterations"] = fit.iterations;
        out["reflected_poles"] = fit.reflected;
        json res = json::array();
        for (const design::cplx p : fit.poles) {
            if (!(p.imag() > 0.0)) continue;
            const design::cplx s = std::log(p) * rate_Hz;
            res.push_back({{"frequency_Hz", std::abs(s) / (2.0 * M_PI)}, {"damping", -s.real() / std::abs(s)}});
        }
        out["resonances"] = res;
        out["model"] = {{"num", fit.model.num}, {"den", fit.model.den}, {"ts", fit.model.ts}};
    } catch (const std::invalid_argument& x) {
        out["error"] = {{"field", "fit_order"}, {"message", std::string("fit_order: ") + x.what()}};
    }
    return out;
}

json result_json_of(const FrfForm& f, const json& request, const hostlink::DeviceFrfRun& d, double rate_Hz) {
    const measure::FrfEstimate& e = d.run.estimate;
    json mag = json::array(), sd = json::array(), resp = json::array();
    for (std::size_t i = 0; i < e.response.size(); ++i) {
        mag.push_back(design::magnitude_db(e.response[i]));
        sd.push_back(finite_or_null(e.std_db[i]));
        resp.push_back({e.response[i].real(), e.response[i].imag()});
    }
    json out = {{"request", request},
                {"signal", d.run.plan.signal},
                {"frequency_Hz", e.frequency_Hz},
                {"response", resp},
                {"magnitude_dB", mag},
                {"phase_deg", unwrapped_phase_deg(e.response)},
                {"std_dB", sd},
                {"lines", e.frequency_Hz.size()},
                {"periods", f.request.periods},
                {"transient_periods", f.request.transient_periods},
                {"rate_Hz", rate_Hz},
                {"device_s", static_cast<double>(d.run.plan.ticks) / rate_Hz},
                {"wall_s", d.run.wall_s},
                {"clipped_samples", d.run.clipped_samples},
                {"limiter_trip", d.run.trip},
                {"warnings", d.run.warnings},
                {"log_hash", format::hex64(d.run.log_hash)},
                {"recording", hostlink::recording_summary(d.record)}};
    if (!d.run.coherence.empty()) out["coherence"] = d.run.coherence;
    if (f.fit_poles > 0) out["fit"] = fit_json(f, e, rate_Hz);
    return out;
}

std::string g17(double x) {
    if (!std::isfinite(x)) return "";
    char b[32];
    std::snprintf(b, sizeof b, "%.17g", x);
    return b;
}

}  // namespace

FrfForm parse_frf_form(const json& j) {
    if (!j.is_object()) throw FieldRefusal("", "the request must be a JSON object");
    FrfForm f;
    measure::FrfRequest& r = f.request;
    std::string order = "";
    for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string& k = it.key();
        const json& v = it.value();
        if (k == "from_Hz") r.from_Hz = form_number(v, "from_Hz");
        else if (k == "to_Hz") r.to_Hz = form_number(v, "to_Hz");
        else if (k == "amplitude_V") r.amplitude_V = form_number(v, "amplitude_V");
        else if (k == "bias_V") r.bias_V = form_number(v, "bias_V");
        else if (k == "periods") r.periods = form_whole(v, "periods", 1e9);
        else if (k == "transient_periods") r.transient_periods = form_whole(v, "transient_periods", 1e9);
        else if (k == "signal") {
            r.signal = v.is_string() ? v.get<std::string>() : "";
            if (r.signal != "multisine" && r.signal != "sweep" && r.signal != "prbs")
                throw FieldRefusal("signal", "signal: must be multisine, sweep or prbs");
        } else if (k == "mode") {
            const std::string m = v.is_string() ? v.get<std::string>() : "";
            if (m != "open" && m != "closed") throw FieldRefusal("mode", "mode: must be open or closed");
            r.closed = m == "closed";
        } else if (k == "restart_stage") {
            if (!v.is_boolean()) throw FieldRefusal("restart_stage", "restart_stage: must be true or false");
            f.restart_stage = v.get<bool>();
        } else if (k == "axis") {
            if (!v.is_string()) throw FieldRefusal("axis", "axis: must be x, y or z");
            f.axis = v.get<std::string>();
        } else if (k == "fit_order") {
            if (!v.is_string()) throw FieldRefusal("fit_order", "fit_order: must be text, N/M");
            order = v.get<std::string>();
        } else {
            throw FieldRefusal("", k + ": unknown field (from_Hz, to_Hz, amplitude_V, bias_V, periods, "
                                       "transient_periods, signal, mode, restart_stage, fit_order, axis)");
        }
    }
    for (const char* k : {"from_Hz", "to_Hz", "amplitude_V"})
        if (!j.contains(k)) throw FieldRefusal(k, std::string(k) + ": required");
    parse_order(order, f.fit_poles, f.fit_zeros);
    return f;
}

FieldRefusal form_refusal(const std::string& plan_message) { return renamed_refusal(plan_message, kOptionFields); }

json FrfJob::start(const json& form) {
    const FrfForm f = parse_frf_form(form);
    const uint8_t axis = axis_field(board_, f.axis);
    try {
        (void)board_.plan_frf(f.request, axis);
    } catch (const BoardBusy&) {
        throw;
    } catch (const std::invalid_argument& e) {
        throw form_refusal(e.what());
    }
    return job_.start(form, [this, f, form, axis](const MeasurementJob::Context& c) {
        hostlink::MeasureOptions o;
        o.restart_stage = f.restart_stage;
        o.axis = axis;
        o.stop_requested = c.stop_requested;
        o.progress = [&](double x) { c.report(x < 1.0 ? "recording" : "estimating", x); };
        try {
            const double rate_Hz = board_.history().rate_Hz();
            const hostlink::DeviceFrfRun d = board_.measure_frf(f.request, o);
            if (f.fit_poles > 0) c.report("fitting", 1.0);
            return result_json_of(f, form, d, rate_Hz);
        } catch (const hostlink::DeviceError& e) {
            // The restart flag is the form's restart_stage.
            if (e.field() == "flags" && f.restart_stage)
                throw FieldRefusal("restart_stage", std::string("the board refused: ") + e.what());
            throw;
        } catch (const std::invalid_argument& e) {
            throw form_refusal(e.what());
        }
    });
}

std::string FrfJob::result_csv() const {
    const json result = job_.result_json();
    if (result.is_null()) return "";
    const bool fit = result.contains("fit") && result["fit"].contains("magnitude_dB");
    std::string out = "frequency_Hz,magnitude_dB,phase_deg,std_dB,re_um_per_V,im_um_per_V";
    if (fit) out += ",fit_magnitude_dB,fit_phase_deg";
    out += "\n";
    auto cell = [](const json& v) { return v.is_number() ? g17(v.get<double>()) : std::string(); };
    for (std::size_t i = 0; i < result["frequency_Hz"].size(); ++i) {
        out += cell(result["frequency_Hz"][i]) + "," + cell(result["magnitude_dB"][i]) + "," +
               cell(result["phase_deg"][i]) + "," + cell(result["std_dB"][i]) + "," + cell(result["response"][i][0]) +
               "," + cell(result["response"][i][1]);
        if (fit) out += "," + cell(result["fit"]["magnitude_dB"][i]) + "," + cell(result["fit"]["phase_deg"][i]);
        out += "\n";
    }
    return out;
}

}  // namespace piezoloop::ui
