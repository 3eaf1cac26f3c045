// piezoloop.design: `piezoloop design c2d`'s report (lti/design_report.hpp)
// for a model given as model-file JSON text or as a file.
#include <optional>
#include <string>

#include <pybind11/stl.h>

#include <vector>

#include "analysis/loop_report.hpp"
#include "bindings.hpp"
#include "json/json_reader.hpp"
#include "lti/design_report.hpp"
#include "lti/model_json.hpp"
#include "lti/sos.hpp"
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
}

}  // namespace piezoloop::py
