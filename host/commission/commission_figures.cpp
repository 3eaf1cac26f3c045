#include "commission/commission_figures.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "lti/freqresp.hpp"

namespace piezoloop::commission {

namespace {

using nlohmann::json;

json series(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
            const std::string& style = "") {
    json s = {{"label", label}, {"x", x}, {"y", y}};
    if (!style.empty()) s["style"] = style;
    return s;
}

json panel(const std::string& title, const std::string& xlabel, const std::string& ylabel, json series_list,
           const std::string& xscale = "linear") {
    return {{"title", title}, {"xlabel", xlabel}, {"ylabel", ylabel}, {"xscale", xscale}, {"series", series_list}};
}

json frf_figure(const Commissioning& c, const std::filesystem::path& dir) {
    const measure::FrfEstimate& e = c.frf.estimate;
    const ModelFit& fit = c.fits[static_cast<std::size_t>(c.chosen_fit)];
    std::vector<double> mag, ph, fit_mag, fit_ph;
    for (std::size_t i = 0; i < e.frequency_Hz.size(); ++i) {
        const design::cplx g = fit_response(fit, e.frequency_Hz[i], c.identified.loop.rate_Hz);
        mag.push_back(design::magnitude_db(e.response[i]));
        ph.push_back(design::phase_deg(e.response[i]));
        fit_mag.push_back(design::magnitude_db(g));
        fit_ph.push_back(design::phase_deg(g));
    }
    const std::string order = std::to_string(fit.poles) + "/" + std::to_string(fit.zeros) + " fit";
    return {{"output", (dir / "frf.png").string()},
            {"title", "open-loop response u (V) -> y (um): measured and fitted"},
            {"columns", 1},
            {"panels", json::array({panel("magnitude", "frequency (Hz)", "dB (um/V)",
                                          {series("measured", e.frequency_Hz, mag), series(order, e.frequency_Hz, fit_mag, "--")},
                                          "log"),
                                    panel("phase", "frequency (Hz)", "deg",
                                          {series("measured", e.frequency_Hz, ph), series(order, e.frequency_Hz, fit_ph, "--")},
                                          "log")})}};
}

json loops_figure(const Commissioning& c, const std::filesystem::path& dir) {
    // At most about 4000 points; the model runs through every sample.
    const std::size_t every = std::max<std::size_t>(1, c.loops.u_V.size() / 4000);
    std::vector<double> u, y, model;
    // The fitted model with its offset, from rest as fitted.
    const std::vector<double> fitted = c.hysteresis ? c.hysteresis->simulate(c.loops.u_V) : std::vector<double>{};
    for (std::size_t i = 0; i < c.loops.u_V.size(); ++i) {
        if (i % every != 0) continue;
        u.push_back(c.loops.u_V[i]);
        y.push_back(c.loops.y_um[i]);
        if (c.hysteresis) model.push_back(fitted[i]);
    }
    json s = json::array({series("measured", u, y)});
    if (c.hysteresis) s.push_back(series("PI model", u, model, "--"));
    return {{"output", (dir / "loops.png").string()},
            {"title", "hysteresis loop, open loop, 5 Hz (the PI model is fitted to the second cycle)"},
            {"columns", 1},
            {"panels", json::array({panel("displacement against command", "u (V)", "y (um)", s)})}};
}

json candidates_figure(const Commissioning& c, const std::filesystem::path& dir) {
    json loop = json::array(), sens = json::array();
    for (const Candidate& k : c.candidates) {
        if (k.measured.loop.empty() || k.feedforward) continue;  // the feedforward does not change the loop
        std::vector<double> l, s;
        for (const design::cplx x : k.measured.loop) {
            l.push_back(design::magnitude_db(x));
            s.push_back(design::magnitude_db(1.0 / (1.0 + x)));
        }
        const std::string label = k.name + (k.passes ? "" : " (refused)");
        loop.push_back(series(label, k.measured.f_Hz, l));
        sens.push_back(series(label, k.measured.f_Hz, s));
    }
    return {{"output", (dir / "candidates.png").string()},
            {"title", "candidates on the measured lines"},
            {"columns", 1},
            {"panels", json::array({panel("|L| = |G K|", "frequency (Hz)", "dB", loop, "log"),
                                    panel("|S| = |1 / (1 + L)| (the check: <= 6 dB)", "frequency (Hz)", "dB", sens, "log")})}};
}

json verification_figure(const Commissioning& c, const std::filesystem::path& dir) {
    // The first run is the check (10 Hz over half the range); the others
    // cover the whole range, drawn in order of frequency.
    std::vector<Verification> whole(c.verification.begin() + 1, c.verification.end());
    std::sort(whole.begin(), whole.end(),
              [](const Verification& a, const Verification& b) { return a.request.frequency_Hz < b.request.frequency_Hz; });
    std::vector<double> f, measured, predicted;
    for (const Verification& v : whole) {
        f.push_back(v.request.frequency_Hz);
        measured.push_back(v.measured.e_max_pct);
        predicted.push_back(v.predicted.e_max_pct);
    }
    const Verification& check = c.verification.front();
    const std::vector<double> f_half{check.request.frequency_Hz}, measured_half{check.measured.e_max_pct},
        predicted_half{check.predicted.e_max_pct};
    json panels = json::array({panel("e_max (% of the triangle's range)", "triangle frequency (Hz)", "%",
                                     {series("measured, whole range", f, measured, "o-"),
                                      series("predicted, whole range", f, predicted, "s--"),
                                      series("measured, half range", f_half, measured_half, "o"),
                                      series("predicted, half range", f_half, predicted_half, "s")},
                                     "log")});
    if (c.closed_frf) {
        // T measured in closed loop, and L / (1 + L) from the open-loop lines.
        const Candidate& k = c.candidates[static_cast<std::size_t>(c.chosen)];
        std::vector<double> measured_t, computed_t;
        for (const design::cplx x : c.closed_frf->complementary_sensitivity) measured_t.push_back(design::magnitude_db(x));
        for (const design::cplx l : k.measured.loop) computed_t.push_back(design::magnitude_db(l / (1.0 + l)));
        panels.push_back(panel("closed loop |T|", "frequency (Hz)", "dB",
                               {series("measured in closed loop", c.closed_frf->estimate.frequency_Hz, measured_t),
                                series("from the open-loop lines", k.measured.f_Hz, computed_t, "--")},
                               "log"));
    }
    return {{"output", (dir / "verification.png").string()},
            {"title", "the chosen loop on the stage: tracking against prediction, closed-loop response"},
            {"columns", 1},
            {"panels", panels}};
}

}  // namespace

nlohmann::json commission_figures(const Commissioning& c, const std::filesystem::path& dir) {
    json out = json::array({frf_figure(c, dir), loops_figure(c, dir), candidates_figure(c, dir)});
    if (!c.verification.empty()) out.push_back(verification_figure(c, dir));
    return out;
}

}  // namespace piezoloop::commission
