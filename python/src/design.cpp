// piezoloop.design: the reports of `piezoloop design c2d|hinf|mixsyn|musyn`,
// `analyze loop|mu` and `reduce` (the host's *_report files) for models
// given as model-file JSON text or as files.
#include <optional>
#include <string>

#include <pybind11/stl.h>

#include <vector>

#include "analysis/loop_report.hpp"
#include "analysis/mu_report.hpp"
#include "ident/reduce_report.hpp"
#include "bindings.hpp"
#include "json/json_reader.hpp"
#include "lti/design_report.hpp"
#include "lti/model_json.hpp"
#include "lti/sos.hpp"
#include "synth/musyn_report.hpp"
#include "synth/plant_json.hpp"
#include "synth/synth_report.hpp"

namespace piezoloop::py {
namespace {

// A model from its JSON text (a dict from Python) or its file; the file's
// name labels the report as the CLI's --model does.
design::Zpk load_model(const std::string& json_text, const std::string& file,
                       const design::ModelParseOptions& opt = {}) {
    if (!file.empty()) return design::load_model_file(file, opt);
    nlohmann::json j;
    try {
        j = hostjson::parse_text(json_text, "model");
    } catch (const hostjson::JsonError& e) {
        throw std::invalid_argument(e.what());
    }
    return design::parse_model(j, "model", opt);
}

// A model argument: (JSON text, file); the file names it in messages.
using ModelArg = std::pair<std::string, std::string>;

std::string model_name(const ModelArg& m, const std::string& fallback) {
    return m.second.empty() ? fallback : m.second;
}

// A model argument whose errors name the argument (as the CLI's --plant).
design::Zpk load_named(const ModelArg& a, const std::string& label, const design::ModelParseOptions& o = {}) {
    try {
        return load_model(a.first, a.second, o);
    } catch (const std::exception& e) {
        throw std::invalid_argument(label + ": " + e.what());
    }
}

}  // namespace

void add_design(pyb::module_& m) {
    m.def(
        "c2d",
        [](const std::string& model_json, const std::string& model_file, double rate_hz, const std::string& method,
           std::optional<double> prewarp_hz, const std::string& format, const std::string& scaling,
           double in_full_scale, double out_full_scale, double headroom, bool check) {
            design::RealiseOptions o;
            o.rate_hz = rate_hz;
            o.format = format;
            o.scaling = scaling;
            o.in_full_scale = in_full_scale;
            o.out_full_scale = out_full_scale;
            o.headroom = headroom;
            o.no_check = !check;
            design::check_realise_options(o);
            design::C2dReport r = design::c2d_report(load_model(model_json, model_file), model_file, rate_hz,
                                                     method, prewarp_hz);
            const bool fit = design::realise(r.discrete, o, r.json);
            r.json["fit"] = fit;
            return to_python(r.json);
        },
        pyb::arg("model_json"), pyb::arg("model_file"), pyb::arg("rate_hz"), pyb::arg("method"),
        pyb::arg("prewarp_hz"), pyb::arg("format"), pyb::arg("scaling"), pyb::arg("in_full_scale"),
        pyb::arg("out_full_scale"), pyb::arg("headroom"), pyb::arg("check"),
        "`piezoloop design c2d`'s JSON (plus \"fit\": the realisation is fit).");

    m.def(
        "analyze_loop",
        [](const ModelArg& plant, const ModelArg& controller, const std::optional<ModelArg>& we,
           const std::optional<ModelArg>& wy, const std::optional<ModelArg>& hm, double rate_hz,
           const std::string& method, const std::string& plant_method, double prewarp_hz,
           const std::vector<double>& phase_lag_hz, double family_rel, bool family) {
            design::LoopModels models;
            models.plant = load_model(plant.first, plant.second);
            models.plant_name = model_name(plant, "plant");
            models.controller = load_model(controller.first, controller.second);
            models.controller_name = model_name(controller, "controller");
            if (we) models.we = load_model(we->first, we->second), models.we_name = model_name(*we, "we");
            if (wy) models.wy = load_model(wy->first, wy->second), models.wy_name = model_name(*wy, "wy");
            if (hm) models.hm = load_model(hm->first, hm->second), models.hm_name = model_name(*hm, "hm");
            design::LoopReportOptions o;
            o.disc.rate_hz = rate_hz;
            o.disc.method = method;
            o.disc.plant_method = plant_method;
            o.disc.prewarp_hz = prewarp_hz;
            o.phase_lag_hz = phase_lag_hz;
            o.family_rel = family_rel;
            o.family = family;
            nlohmann::json out;
            {
                // H-inf bisections and the family take a while.
                pyb::gil_scoped_release release;
                out = design::loop_report(models, o).json;
            }
            return to_python(out);
        },
        pyb::arg("plant"), pyb::arg("controller"), pyb::arg("we"), pyb::arg("wy"), pyb::arg("hm"),
        pyb::arg("rate_hz"), pyb::arg("method"), pyb::arg("plant_method"), pyb::arg("prewarp_hz"),
        pyb::arg("phase_lag_hz"), pyb::arg("family_rel"), pyb::arg("family"),
        "`piezoloop analyze loop`'s JSON.");

    m.def(
        "mixsyn",
        [](const ModelArg& plant, const ModelArg& w1, const std::optional<ModelArg>& w2,
           const std::optional<ModelArg>& w3, double gamma_tol, double gamma_max, double backoff) {
            design::SynthSettings st;
            st.gamma_tol = gamma_tol;
            st.gamma_max = gamma_max;
            st.backoff = backoff;
            (void)design::hinf_options(st);
            design::ModelParseOptions improper_ok;
            improper_ok.allow_improper = true;  // so mixsyn names the improper weight itself
            auto named = [&](const ModelArg& a, const std::string& label, const design::ModelParseOptions& o) {
                return design::NamedModel{load_model(a.first, a.second, o), model_name(a, label)};
            };
            const design::NamedModel g = named(plant, "plant", {});
            const design::NamedModel n1 = named(w1, "w1", improper_ok);
            std::optional<design::NamedModel> n2, n3;
            if (w2) n2 = named(*w2, "w2", improper_ok);
            if (w3) n3 = named(*w3, "w3", improper_ok);
            nlohmann::json out;
            {
                pyb::gil_scoped_release release;
                out = design::mixsyn_report(g, n1, n2, n3, st).json;
            }
            return to_python(out);
        },
        pyb::arg("plant"), pyb::arg("w1"), pyb::arg("w2"), pyb::arg("w3"), pyb::arg("gamma_tol"),
        pyb::arg("gamma_max"), pyb::arg("backoff"), "`piezoloop design mixsyn`'s JSON.");

    m.def(
        "hinf",
        [](const std::string& plant_json, const std::string& plant_file, double gamma_tol, double gamma_max,
           double backoff) {
            design::SynthSettings st;
            st.gamma_tol = gamma_tol;
            st.gamma_max = gamma_max;
            st.backoff = backoff;
            (void)design::hinf_options(st);
            design::GeneralisedPlant p;
            if (!plant_file.empty()) {
                p = design::load_plant_file(plant_file);
            } else {
                try {
                    p = design::parse_plant(hostjson::parse_text(plant_json, "plant"));
                } catch (const hostjson::JsonError& e) {
                    throw std::invalid_argument(e.what());
                }
            }
            nlohmann::json out;
            {
                pyb::gil_scoped_release release;
                out = design::hinf_report(p, plant_file.empty() ? "plant" : plant_file, st).json;
            }
            return to_python(out);
        },
        pyb::arg("plant_json"), pyb::arg("plant_file"), pyb::arg("gamma_tol"), pyb::arg("gamma_max"),
        pyb::arg("backoff"), "`piezoloop design hinf`'s JSON.");

    m.def(
        "musyn",
        [](const ModelArg& plant, const ModelArg& w1, const ModelArg& hm, const std::optional<ModelArg>& w2,
           const std::optional<ModelArg>& w3, int iterations, int d_order, double gamma_tol, double backoff,
           const std::optional<pyb::function>& on_iteration) {
            design::ModelParseOptions improper_ok;
            improper_ok.allow_improper = true;  // so the synthesis names the improper weight itself
            design::MusynProblem pb;
            pb.plant = load_named(plant, "plant");
            pb.w1 = load_named(w1, "w1", improper_ok);
            pb.hm = load_named(hm, "hm", improper_ok);
            if (w2) pb.w2 = load_named(*w2, "w2", improper_ok);
            if (w3) pb.w3 = load_named(*w3, "w3", improper_ok);
            design::MusynSettings st;
            st.iterations = iterations;
            st.d_order = d_order;
            st.gamma_tol = gamma_tol;
            st.backoff = backoff;
            const design::MusynNames names{model_name(plant, "plant"), model_name(w1, "w1"), model_name(hm, "hm"),
                                           w2 ? model_name(*w2, "w2") : "", w3 ? model_name(*w3, "w3") : ""};
            nlohmann::json out;
            {
                pyb::gil_scoped_release release;
                out = design::musyn_report(pb, names, st, [&](const design::DkRecord& r) {
                          if (!on_iteration) return;
                          pyb::gil_scoped_acquire acquire;
                          (*on_iteration)(r.iteration, r.gamma, r.mu_peak);
                      }).json;
            }
            return to_python(out);
        },
        pyb::arg("plant"), pyb::arg("w1"), pyb::arg("hm"), pyb::arg("w2"), pyb::arg("w3"), pyb::arg("iterations"),
        pyb::arg("d_order"), pyb::arg("gamma_tol"), pyb::arg("backoff"), pyb::arg("on_iteration"),
        "`piezoloop design musyn`'s JSON.");

    m.def(
        "analyze_mu",
        [](const ModelArg& plant, const ModelArg& controller, const ModelArg& hm, const ModelArg& w1,
           const std::optional<ModelArg>& w3, const std::optional<ModelArg>& w2) {
            design::MuLoopModels models;
            models.plant = load_named(plant, "plant");
            models.controller = load_named(controller, "controller");
            models.hm = load_named(hm, "hm");
            models.w1 = load_named(w1, "w1");
            if (w3) models.w3 = load_named(*w3, "w3"), models.has_w3 = true;
            if (w2) models.w2 = load_named(*w2, "w2"), models.has_w2 = true;
            nlohmann::json out;
            {
                pyb::gil_scoped_release release;
                out = design::mu_report(models).json;
            }
            return to_python(out);
        },
        pyb::arg("plant"), pyb::arg("controller"), pyb::arg("hm"), pyb::arg("w1"), pyb::arg("w3"), pyb::arg("w2"),
        "`piezoloop analyze mu`'s JSON.");

    m.def(
        "pi_notch",
        [](const ModelArg& plant, double crossover_Hz, double pm_min_deg, double gm_min_db) {
            design::PiNotchOptions o;
            o.pm_min_deg = pm_min_deg;
            o.gm_min_db = gm_min_db;
            const nlohmann::json out =
                design::pi_notch_json(design::design_pi_notch(load_named(plant, "plant"), crossover_Hz, o));
            return to_python(out);
        },
        pyb::arg("plant"), pyb::arg("crossover_Hz"), pyb::arg("pm_min_deg"), pyb::arg("gm_min_db"),
        "`piezoloop design pi-notch`'s JSON (without command and plant_file).");

    m.def(
        "reduce",
        [](const ModelArg& model, int order) { return to_python(design::reduce_report(load_named(model, "model"), order)); },
        pyb::arg("model"), pyb::arg("order"), "`piezoloop reduce`'s JSON.");
}

}  // namespace piezoloop::py
