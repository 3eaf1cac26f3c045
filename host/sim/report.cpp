#include "sim/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "piezoloop/limits.hpp"
#include "sim/rc_check.hpp"

namespace piezoloop::sim {

namespace {

std::string fixed(double x, int decimals) {
    if (!std::isfinite(x)) return "–";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, x);
    return buf;
}

// Three significant digits, plain notation where reasonable.
std::string sig(double x, int digits = 3) {
    if (!std::isfinite(x)) return "–";
    if (x == 0.0) return "0";
    const double a = std::fabs(x);
    if (a >= 1e-3 && a < 1e6) {
        const int mag = static_cast<int>(std::floor(std::log10(a)));
        return fixed(x, std::max(0, digits - 1 - mag));
    }
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*g", digits, x);
    return buf;
}

// Up to 3 significant digits without trailing zeros (0.01, 12, 1500).
std::string short_num(double x) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3g", x);
    std::string s = buf;
    if (s.find('e') != std::string::npos) {
        std::snprintf(buf, sizeof buf, "%.0f", x);
        if (std::fabs(x) >= 1.0) return buf;
    }
    return s;
}

std::string freq_label(double f) { return short_num(f) + " Hz"; }

std::string table_row(const std::vector<std::string>& cells) {
    std::string s = "|";
    for (const std::string& c : cells) s += " " + c + " |";
    return s + "\n";
}

std::string table_rule(size_t n) {
    std::string s = "|";
    for (size_t i = 0; i < n; ++i) s += i == 0 ? " --- |" : " ---: |";
    return s + "\n";
}

std::string slug(const std::string& s) {
    std::string o;
    for (const char c : s) o += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
    return o;
}

// Cells of one case, in the experiment's order.
std::vector<const CellResult*> cells_of(const ExperimentResult& e, const std::string& name) {
    std::vector<const CellResult*> v;
    for (const CellResult& c : e.cells)
        if (c.case_name == name) v.push_back(&c);
    return v;
}

const CaseSpec& case_of(const Scenario& s, const std::string& name) { return s.find_case(name); }

bool is_open_loop(const CaseSpec& c) { return c.feedback.kind == "none" && c.feedforward.kind == "gain"; }

std::string cell_failure(const CellResult& c) {
    if (!c.error.empty()) return "error";
    if (c.run.trip != TripReason::kNone) return std::string("trip: ") + trip_reason_name(c.run.trip);
    return "";
}

nlohmann::json series(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                      const std::string& style = "") {
    nlohmann::json s = {{"label", label}, {"x", x}, {"y", y}};
    if (!style.empty()) s["style"] = style;
    return s;
}

std::vector<double> to_d(const std::vector<float>& v) { return {v.begin(), v.end()}; }

std::vector<double> time_axis(const RunLog& l, double rate, uint64_t origin, double scale) {
    std::vector<double> t;
    t.reserve(l.tick.size());
    for (const uint64_t k : l.tick) t.push_back(static_cast<double>(k - origin) / rate * scale);
    return t;
}

std::string describe_hysteresis(const HysteresisSpec& h) {
    if (h.kind == "none") return "none (linear, " + sig(h.gain_um_per_V) + " µm/V)";
    if (h.kind == "pi")
        return "PI model, " + std::to_string(h.pi.count) + " play operators + linear term (p0 = " + sig(h.pi.p0) +
               " µm/V)";
    if (h.kind == "shan_pi")
        return "Shan2012 PI model (exponential density), " + std::to_string(h.pi.count) +
               " play operators, input " + sig(h.in_gain) + " × v + " + sig(h.in_offset) + ", output × " +
               sig(h.out_gain) + " µm";
    return "Dahl model";
}

std::string describe_ff(const CaseSpec& c) {
    const FeedforwardSpec& f = c.feedforward;
    if (f.kind == "none") return "–";
    if (f.kind == "gain") return "gain " + sig(f.V_per_um) + " V/µm";
    if (f.kind == "pi_inverse") return std::string("analytic inverse PI of the ") + (f.of == "plant" ? "case's" : "stage's") + " model";
    if (f.kind == "pi_compensator") return "PI compensator (" + std::to_string(f.pi.count) + " operators)";
    return f.identify ? "Dahl (identified)" : "Dahl (given parameters)";
}

std::string describe_fb(const CaseSpec& c, const BuiltCase* b) {
    const FeedbackSpec& f = c.feedback;
    if (f.kind == "none") return "–";
    std::string unit = f.error_per_um != 1.0 ? " (error × " + sig(f.error_per_um) + " /µm)" : "";
    if (f.kind == "pid")
        return "PI(D): Kp " + sig(f.pid.kp) + ", Ki " + sig(f.pid.ki_per_s) + " /s" +
               (f.pid.kd_s != 0.0f ? ", Kd " + sig(f.pid.kd_s) + " s" : "") + unit;
    std::string s = "continuous model (" + std::to_string(f.model->zpk.poles.size()) + " poles), " + f.method;
    if (f.prewarp_Hz > 0.0) s += " pre-warped at " + sig(f.prewarp_Hz) + " Hz";
    if (b) s += ", " + std::to_string(b->controller_sections) + " sections";
    return s + unit;
}

std::string describe_rc(const CaseSpec& c) {
    if (!c.rc.enabled) return "–";
    const RepetitiveConfig& r = c.rc.rc;
    return std::string("N = ") + (c.rc.period_samples ? std::to_string(c.rc.period_samples) : "rate/f") +
           ", m1 = " + std::to_string(r.m1) + ", m2 = " + std::to_string(r.m2) + ", k_rc = " + sig(r.k_rc);
}

}  // namespace

double bandwidth_3db_Hz(const std::vector<const CellResult*>& cells) {
    const double level = 1.0 / std::sqrt(2.0);
    double f_prev = 0.0, g_prev = 0.0;
    bool have_prev = false;
    for (const CellResult* c : cells) {
        if (!c->error.empty()) continue;
        const double g = std::abs(tone_gain(c->run));
        if (have_prev && g_prev >= level && g < level) {
            const double t = (g_prev - level) / (g_prev - g);
            return std::exp(std::log(f_prev) + t * (std::log(c->frequency_Hz) - std::log(f_prev)));
        }
        f_prev = c->frequency_Hz;
        g_prev = g;
        have_prev = true;
    }
    return -1.0;
}

std::string scenario_report(const ScenarioResult& r, std::vector<ReportFigure>& figures) {
    const Scenario& s = *r.scenario;
    std::ostringstream md;
    md << "## " << s.title << "\n\n";
    if (!s.source.empty()) md << "Source: " << s.source << ".\n\n";
    md << "Scenario file: `" << s.file.filename().string() << "`; loop rate " << sig(s.rate_Hz / 1e3) << " kHz.\n\n";
    if (!s.notes.empty()) {
        md << "### What the scenario assumes\n\n";
        for (const std::string& n : s.notes) md << "- " << n << "\n";
        md << "\n";
    }

    // Stage.
    const PlantSpec& p = s.plant;
    md << "### Stage\n\n";
    md << "- DAC: " << (p.dac.bits ? std::to_string(p.dac.bits) + " bit" : std::string("ideal")) << ", " << sig(p.dac.min)
       << " … " << sig(p.dac.max) << " V\n";
    md << "- Amplifier: gain " << sig(p.amplifier.gain) << " V/V, input " << sig(p.amplifier.input_min_V) << " … "
       << sig(p.amplifier.input_max_V) << " V, output " << sig(p.amplifier.output_min_V) << " … "
       << sig(p.amplifier.output_max_V) << " V, bandwidth "
       << (p.amplifier.bandwidth_Hz > 0.0f ? sig(p.amplifier.bandwidth_Hz) + " Hz" : std::string("not limited")) << "\n";
    md << "- Hysteresis: " << describe_hysteresis(p.hysteresis) << "\n";
    if (p.dynamics) {
        md << "- Dynamics: " << p.dynamics->source << ", " << p.dynamics->zpk.poles.size() << " poles, "
           << p.dynamics->zpk.zeros.size() << " zeros; float stage: " << p.discretisation;
        int sections = 0;
        for (const auto& [name, b] : r.built) sections = std::max(sections, b.plant_sections);
        if (sections) md << ", " << sections << " biquad sections";
        md << "\n";
    }
    md << "- Sensor: " << sig(p.sensor.gain) << " per µm, bandwidth "
       << (p.sensor.bandwidth_Hz > 0.0f ? sig(p.sensor.bandwidth_Hz) + " Hz" : std::string("not limited"))
       << ", noise " << sig(p.sensor.noise_rms) << " rms (seed " << p.sensor.seed << ")\n";
    md << "- ADC: " << (p.adc.bits ? std::to_string(p.adc.bits) + " bit" : std::string("ideal")) << ", " << sig(p.adc.min)
       << " … " << sig(p.adc.max) << "\n";
    md << "- Command limits " << sig(s.limits.u_min_V) << " … " << sig(s.limits.u_max_V) << " V, slew "
       << sig(s.limits.slew_V_per_s) << " V/s\n\n";

    // Cases.
    md << "### Controller cases\n\n";
    md << table_row({"case", "feedforward", "feedback", "repetitive control", "core"}) << table_rule(5);
    for (const CaseSpec& c : s.cases) {
        const auto it = r.built.find(c.name);
        const BuiltCase* b = it == r.built.end() ? nullptr : &it->second;
        std::string label = c.label;
        if (c.plant_hysteresis) label += " (stage: " + describe_hysteresis(*c.plant_hysteresis) + ")";
        md << table_row({label, describe_ff(c), describe_fb(c, b), describe_rc(c), to_string(c.sample)});
    }
    md << "\n";
    for (const CaseSpec& c : s.cases) {
        const auto it = r.built.find(c.name);
        if (!c.note.empty()) md << "- *" << c.label << "*: " << c.note << "\n";
        if (it == r.built.end()) continue;
        for (const std::string& n : it->second.notes) md << "- *" << c.label << "*: " << n << "\n";
        if (const auto& d = it->second.dahl) {
            const DahlParams& q = d->params;
            md << "- *" << c.label << "*: Dahl compensator identified (ident/dahl_fit, docs/models.md) from " << d->data
               << ": α1 = " << sig(q.alpha1) << ", α2 = " << sig(q.alpha2) << ", β1 = " << sig(q.beta1)
               << ", β2 = " << sig(q.beta2) << ", γa = " << sig(q.gamma_a) << " (held), ga = " << sig(q.ga)
               << " µm/V; fit error " << sig(d->fit.rms_error) << " µm rms (" << sig(d->fit.nrmse_percent)
               << " % NRMSE), " << d->fit.evaluations << " model evaluations.\n";
        }
    }
    md << "\n";

    // Experiments.
    for (const ExperimentResult& e : r.experiments) {
        const ExperimentSpec& x = *e.spec;
        md << "### " << x.title << "\n\n";
        if (!x.note.empty()) md << x.note << "\n\n";
        const std::string fig_base = "figures/" + slug(s.name) + "_" + slug(x.name);
        if (x.kind == "loops") {
            const bool volts = !x.amplitudes_V.empty();
            const std::string wave = x.waveform_name;
            md << short_num(x.frequencies_Hz.front()) << " Hz " << wave << "s, " << (x.offset == "unipolar" ? "from 0" : "centred on 0")
               << "; hysteresis % of the measured output against the reference (docs/models.md) on the last of "
               << x.periods << " periods";
            if (volts) md << "; references given as peak-to-peak piezo voltage (× " << sig(s.nominal_um_per_V) << " µm/V)";
            md << ".\n\n";
            std::vector<std::string> head{"Hysteresis %"};
            const auto first = cells_of(e, x.cases.front());
            for (const CellResult* c : first) head.push_back(volts ? short_num(c->amplitude_V) + " V" : short_num(c->range_um) + " µm");
            md << table_row(head) << table_rule(head.size());
            for (const std::string& n : x.cases) {
                std::vector<std::string> row{case_of(s, n).label};
                for (const CellResult* c : cells_of(e, n)) {
                    std::string v = c->error.empty() ? fixed(c->run.hysteresis_pct, 2) : "error";
                    const std::string f = cell_failure(*c);
                    if (!f.empty() && c->error.empty()) v += " (" + f + ")";
                    row.push_back(v);
                }
                md << table_row(row);
            }
            md << "\n";
            // Figure: output against input, one panel per case.
            nlohmann::json panels = nlohmann::json::array();
            for (const std::string& n : x.cases) {
                const CaseSpec& c = case_of(s, n);
                const bool ol = is_open_loop(c) && volts;
                nlohmann::json pan = {{"title", c.label},
                                      {"xlabel", ol ? "piezo voltage (V)" : "reference r (µm)"},
                                      {"ylabel", "measured y (µm)"}};
                for (const CellResult* cell : cells_of(e, n)) {
                    if (!cell->error.empty()) continue;
                    const RunLog& l = cell->run.log;
                    pan["series"].push_back(series(volts ? short_num(cell->amplitude_V) + " V" : short_num(cell->range_um) + " µm",
                                                   ol ? to_d(l.v_piezo_V) : to_d(l.r_um), to_d(l.y_um)));
                }
                panels.push_back(pan);
            }
            figures.push_back({fig_base + ".png", {{"title", s.name + ": " + x.title}, {"panels", panels}}});
        } else if (x.kind == "tracking") {
            md << x.waveform_name << " references, " << (x.offset == "unipolar" ? "from 0" : "centred on 0")
               << "; figures on the last of " << x.periods << " periods"
               << (x.min_duration_s > 0 ? " (at least " + sig(x.min_duration_s) + " s)" : std::string()) << ".\n\n";
            for (const double a : x.amplitudes_um) {
                std::vector<std::string> head{short_num(a) + " µm p-p: e_max % / e_rms %"};
                for (const double f : x.frequencies_Hz) head.push_back(freq_label(f));
                md << table_row(head) << table_rule(head.size());
                for (const std::string& n : x.cases) {
                    std::vector<std::string> row{case_of(s, n).label};
                    for (const CellResult* c : cells_of(e, n)) {
                        if (c->range_um != a) continue;
                        if (!c->error.empty()) {
                            row.push_back("error");
                            continue;
                        }
                        std::string v = fixed(c->run.tracking.e_max_pct, 2) + " / " + fixed(c->run.tracking.e_rms_pct, 2);
                        const std::string f = cell_failure(*c);
                        if (!f.empty()) v += " (" + f + ")";
                        row.push_back(v);
                    }
                    md << table_row(row);
                }
                md << "\n";
                head[0] = short_num(a) + " µm p-p: e_max µm / e_rms µm";
                md << table_row(head) << table_rule(head.size());
                for (const std::string& n : x.cases) {
                    std::vector<std::string> row{case_of(s, n).label};
                    for (const CellResult* c : cells_of(e, n)) {
                        if (c->range_um != a) continue;
                        row.push_back(c->error.empty() ? sig(c->run.tracking.e_max_um) + " / " + sig(c->run.tracking.e_rms_um)
                                                       : "error");
                    }
                    md << table_row(row);
                }
                md << "\n";
            }
            // Figure: tracking error over the last period, one panel per frequency.
            nlohmann::json panels = nlohmann::json::array();
            const double a0 = x.amplitudes_um.front();
            for (const double f : x.frequencies_Hz) {
                const double period_s = 1.0 / f;
                const double scale = period_s < 0.5 ? 1e3 : 1.0;
                nlohmann::json pan = {{"title", freq_label(f)},
                                      {"xlabel", scale == 1e3 ? "time in the period (ms)" : "time in the period (s)"},
                                      {"ylabel", "e = r − y (µm)"}};
                for (const std::string& n : x.cases)
                    for (const CellResult* c : cells_of(e, n)) {
                        if (c->frequency_Hz != f || c->range_um != a0 || !c->error.empty() || c->run.log.tick.empty()) continue;
                        const RunLog& l = c->run.log;
                        std::vector<double> err;
                        for (size_t i = 0; i < l.r_um.size(); ++i) err.push_back(static_cast<double>(l.r_um[i]) - l.y_um[i]);
                        // A Q31 case dashed: it usually lies on its float twin.
                        const CaseSpec& cs = case_of(s, n);
                        pan["series"].push_back(series(cs.label, time_axis(l, s.rate_Hz, l.tick.front(), scale), err,
                                                       cs.sample == SampleType::kQ31 ? "--" : ""));
                    }
                panels.push_back(pan);
            }
            figures.push_back({fig_base + ".png", {{"title", s.name + ": " + x.title + " (" + sig(a0) + " µm p-p)"}, {"panels", panels}}});
        } else if (x.kind == "bode") {
            md << "Sinusoids of " << sig(x.amplitudes_um.front()) << " µm peak-to-peak; y/r from the DFT bin of the last of "
               << x.periods << " periods.\n\n";
            std::vector<std::string> head{"case", "−3 dB bandwidth"};
            for (const double f : x.frequencies_Hz) head.push_back(freq_label(f));
            md << table_row(head) << table_rule(head.size());
            nlohmann::json mag = {{"title", "magnitude"}, {"xlabel", "frequency (Hz)"}, {"ylabel", "|y/r| (dB)"}, {"xscale", "log"}};
            nlohmann::json ph = {{"title", "phase"}, {"xlabel", "frequency (Hz)"}, {"ylabel", "phase of y/r (°)"}, {"xscale", "log"}};
            for (const std::string& n : x.cases) {
                const auto cs = cells_of(e, n);
                const double bw = bandwidth_3db_Hz(cs);
                std::vector<std::string> row{case_of(s, n).label, bw > 0 ? sig(bw) + " Hz" : "> " + freq_label(x.frequencies_Hz.back())};
                std::vector<double> fs, db, deg;
                double unwrap = 0.0, last = 0.0;
                for (const CellResult* c : cs) {
                    if (!c->error.empty()) {
                        row.push_back("error");
                        continue;
                    }
                    const auto g = tone_gain(c->run);
                    double d = std::arg(g) * 180.0 / M_PI;
                    if (!fs.empty()) {
                        while (d + unwrap - last > 180.0) unwrap -= 360.0;
                        while (d + unwrap - last < -180.0) unwrap += 360.0;
                    }
                    last = d + unwrap;
                    fs.push_back(c->frequency_Hz);
                    db.push_back(20.0 * std::log10(std::abs(g)));
                    deg.push_back(last);
                    row.push_back(fixed(db.back(), 2) + " dB, " + fixed(last, 1) + "°");
                }
                md << table_row(row);
                mag["series"].push_back(series(case_of(s, n).label, fs, db, "o-"));
                ph["series"].push_back(series(case_of(s, n).label, fs, deg, "o-"));
            }
            md << "\n";
            figures.push_back({fig_base + ".png", {{"title", s.name + ": " + x.title}, {"panels", {mag, ph}}}});
        } else if (x.kind == "steps") {
            md << "Levels";
            for (const double v : x.steps_um) md << " " << sig(v);
            md << " µm, each held " << sig(x.hold_s * 1e3) << " ms. Overshoot in % of the step, settling to ±2 % of the step.\n\n";
            md << table_row({"case", "max overshoot %", "max 2 % settling (ms)", "error at the end of the holds (µm, max)"})
               << table_rule(4);
            nlohmann::json pan = {{"title", "steps"}, {"xlabel", "time (ms)"}, {"ylabel", "µm"}};
            bool ref_drawn = false;
            for (const std::string& n : x.cases) {
                const auto cs = cells_of(e, n);
                if (cs.empty() || !cs.front()->error.empty()) {
                    md << table_row({case_of(s, n).label, "error", "", ""});
                    continue;
                }
                const RunLog& l = cs.front()->run.log;
                const uint64_t hold = static_cast<uint64_t>(std::llround(x.hold_s * s.rate_Hz));
                double over = 0.0, settle = 0.0, end_err = 0.0;
                for (size_t k = 1; k < x.steps_um.size(); ++k) {
                    const double from = x.steps_um[k - 1], to = x.steps_um[k], step = to - from;
                    if (step == 0.0) continue;
                    const uint64_t t0 = k * hold, t1 = (k + 1) * hold;
                    double last_out = -1.0, final_err = 0.0;
                    for (size_t i = 0; i < l.tick.size(); ++i) {
                        if (l.tick[i] < t0 || l.tick[i] >= t1) continue;
                        const double y = l.y_um[i];
                        over = std::max(over, 100.0 * (y - to) / step);
                        if (std::fabs(y - to) > 0.02 * std::fabs(step)) last_out = static_cast<double>(l.tick[i] - t0);
                        final_err = std::fabs(y - to);
                    }
                    settle = std::max(settle, (last_out + 1.0) / s.rate_Hz * 1e3);
                    end_err = std::max(end_err, final_err);
                }
                md << table_row({case_of(s, n).label, fixed(over, 1), fixed(settle, 2), sig(end_err)});
                const auto t = time_axis(l, s.rate_Hz, 0, 1e3);
                if (!ref_drawn) {
                    pan["series"].push_back(series("reference", t, to_d(l.r_um), "k--"));
                    ref_drawn = true;
                }
                pan["series"].push_back(series(case_of(s, n).label, t, to_d(l.y_um)));
            }
            md << "\n";
            figures.push_back({fig_base + ".png", {{"title", s.name + ": " + x.title}, {"panels", {pan}}}});
        } else {  // growth
            md << "RMS tracking error per reference period over " << sig(x.min_duration_s * 1e3)
               << " ms: a loop that is not L2-stable shows a growing oscillation.\n\n";
            md << table_row({"case", "frequency", "e_rms first period (µm)", "smallest (µm)", "last (µm)", "last / smallest",
                             "verdict"})
               << table_rule(7);
            nlohmann::json et = {{"title", "tracking error"}, {"xlabel", "time (ms)"}, {"ylabel", "e (µm)"}};
            nlohmann::json pr = {{"title", "RMS error per period"}, {"xlabel", "period"}, {"ylabel", "e_rms (µm)"}, {"yscale", "log"}};
            for (const std::string& n : x.cases)
                for (const CellResult* c : cells_of(e, n)) {
                    if (!c->error.empty()) {
                        md << table_row({case_of(s, n).label, freq_label(c->frequency_Hz), "error", "", "", "", c->error});
                        continue;
                    }
                    const auto& v = c->run.period_e_rms_um;
                    if (v.empty()) continue;
                    const double mn = *std::min_element(v.begin(), v.end());
                    const double ratio = v.back() / std::max(mn, 1e-12);
                    const std::string verdict = ratio > 3.0 || c->run.trip != TripReason::kNone ? "grows (unstable)" : "bounded";
                    md << table_row({case_of(s, n).label, freq_label(c->frequency_Hz), sig(v.front()), sig(mn), sig(v.back()),
                                     sig(ratio), verdict + (cell_failure(*c).empty() ? "" : ", " + cell_failure(*c))});
                    const RunLog& l = c->run.log;
                    std::vector<double> err, idx;
                    for (size_t i = 0; i < l.r_um.size(); ++i) err.push_back(static_cast<double>(l.r_um[i]) - l.y_um[i]);
                    for (size_t i = 0; i < v.size(); ++i) idx.push_back(static_cast<double>(i + 1));
                    et["series"].push_back(series(case_of(s, n).label, time_axis(l, s.rate_Hz, 0, 1e3), err));
                    pr["series"].push_back(series(case_of(s, n).label, idx, v));
                }
            md << "\n";
            // The conditions of docs/models.md, 'Repetitive control', on the sampled
            // linear loop (analysis/rc_analysis).
            std::string rows;
            for (const std::string& n : x.cases) {
                const CaseSpec& cs = case_of(s, n);
                std::optional<design::RcAnalysis> a;
                try {
                    a = rc_conditions(s, cs, x.frequencies_Hz.front());
                } catch (const std::exception& ex) {
                    rows += table_row({cs.label, std::string("analysis failed: ") + ex.what(), "", "", "", ""});
                    continue;
                }
                if (!a) continue;
                const std::string inv = cs.feedforward.kind == "pi_inverse"
                                            ? (cs.feedforward.placement == "series" ? " (the inverse in series removes the hysteresis from the loop)"
                                                                                    : " (the feedforward inverse leaves it in the loop)")
                                            : "";
                rows += table_row(
                    {cs.label, fixed(a->max_phase_deg, 1) + "° " + (a->phase_ok ? "(ok)" : "(fails)"),
                     sig(a->k_rc_max) + (a->gain_ok ? " (ok)" : " (fails)"),
                     a->rc_max_abs_root ? sig(*a->rc_max_abs_root, 6) : std::string("–"),
                     sig(a->g0) + " vs " + (a->gain_margin_rc ? sig(*a->gain_margin_rc) : std::string("∞")) +
                         (a->g0_ok ? " (ok)" : " (fails)"),
                     sig(a->density_l1) + " vs " + sig(a->density_bound) + (a->density_ok ? " (ok)" : " (fails)") + inv});
            }
            if (!rows.empty()) {
                md << "Repetitive-control conditions (docs/models.md) on the sampled linear loop L = Gc · G_zoh with the hysteresis as v = g0 u + η "
                      "(analysis/rc_analysis): (3) max |θT + θ2| below Q's cutoff, (2) largest k_rc, the largest root of "
                      "the linear RC loop, (15) g0 against the gain margin M_GL, (21) Σ|d(γj)| against 1 / (|g0| ‖G2‖∞).\n\n";
                md << table_row({"case", "(3) max |θ|", "(2) k_rc max", "linear RC loop, max |z|", "(15) g0 vs M_GL",
                                 "(21) Σ|d| vs bound"})
                   << table_rule(6) << rows << "\n";
            }
            figures.push_back({fig_base + ".png", {{"title", s.name + ": " + x.title}, {"panels", {et, pr}}}});
        }
        md << "![" << x.title << "](" << fig_base << ".png)\n\n";
    }

    // Fidelities.
    if (!r.fidelity_pairs.empty()) {
        md << "### Float (board) fidelity against double (continuous) fidelity\n\n";
        md << "Float: the stage model the emulated boards run (common/piezoloop/stage_model.hpp), linear parts discretised at "
              "the loop rate. Double: the same chain with the continuous dynamics integrated exactly over "
           << "sub-steps of the tick (sim/stage_double.hpp). Same controller (the core) in both.\n\n";
        md << table_row({"case", "run", "e_max µm float / double", "e_rms µm float / double", "hysteresis % float / double",
                         "max |Δy| over the period (µm)"})
           << table_rule(6);
        for (size_t i = 0; i + 1 < r.fidelity_pairs.size(); i += 2) {
            const CellResult& a = r.fidelity_pairs[i];
            const CellResult& b = r.fidelity_pairs[i + 1];
            const std::string run = freq_label(a.frequency_Hz) + ", " + short_num(a.range_um) + " µm";
            if (!a.error.empty() || !b.error.empty()) {
                md << table_row({a.case_label, run, "error", "", "", ""});
                continue;
            }
            double dy = 0.0;
            const size_t n = std::min(a.run.log.y_um.size(), b.run.log.y_um.size());
            for (size_t k = 0; k < n; ++k) dy = std::max(dy, std::fabs(static_cast<double>(a.run.log.y_um[k]) - b.run.log.y_um[k]));
            md << table_row({a.case_label, run, sig(a.run.tracking.e_max_um) + " / " + sig(b.run.tracking.e_max_um),
                             sig(a.run.tracking.e_rms_um) + " / " + sig(b.run.tracking.e_rms_um),
                             fixed(a.run.hysteresis_pct, 2) + " / " + fixed(b.run.hysteresis_pct, 2), sig(dy)});
        }
        md << "\n";
    }

    // Errors and timing.
    size_t runs = 0;
    double sim_s = 0.0, cpu_s = 0.0;
    std::set<std::string> errors;
    for (const ExperimentResult& e : r.experiments)
        for (const CellResult& c : e.cells) {
            ++runs;
            sim_s += c.run.simulated_s;
            cpu_s += c.run.wall_s;
            if (!c.error.empty()) errors.insert(c.case_label + ": " + c.error);
        }
    for (const CellResult& c : r.fidelity_pairs)
        if (!c.error.empty()) errors.insert(c.case_label + ": " + c.error);
    if (!errors.empty()) {
        md << "### Runs that could not be made\n\n";
        for (const std::string& e : errors) md << "- " << e << "\n";
        md << "\n";
    }
    md << "*" << runs << " runs, " << sig(sim_s) << " s simulated in " << sig(cpu_s) << " s of loop time ("
       << sig(cpu_s > 0 ? sim_s / cpu_s : 0.0) << "× real time per thread); scenario wall time " << sig(r.wall_s)
       << " s.*\n\n";
    return md.str();
}

}  // namespace piezoloop::sim
