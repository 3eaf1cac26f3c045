#include "lti/model_json.hpp"
#include "lti/text.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "lti/lti_convert.hpp"

namespace piezoloop::design {
namespace {

using nlohmann::json;

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    throw std::invalid_argument(cat(path, ": ", what));
}

std::string index_path(const std::string& path, size_t i) { return cat(path, "[", std::to_string(i), "]"); }

double number(const json& v, const std::string& path) {
    if (!v.is_number()) fail(path, cat("must be a number, got ", std::string(v.type_name())));
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail(path, "must be finite");
    return d;
}

std::vector<double> coefficients(const json& j, const std::string& path) {
    if (!j.is_array()) fail(path, "must be an array of numbers (descending powers)");
    if (j.empty()) fail(path, "must not be empty");
    std::vector<double> out;
    for (size_t i = 0; i < j.size(); ++i) out.push_back(number(j[i], index_path(path, i)));
    return out;
}

std::vector<cplx> roots(const json& j, const std::string& path) {
    if (!j.is_array()) fail(path, "must be an array of roots, each [re, im] or a real number");
    std::vector<cplx> out;
    for (size_t i = 0; i < j.size(); ++i) {
        const std::string p = index_path(path, i);
        const json& r = j[i];
        if (r.is_number()) {
            out.emplace_back(number(r, p), 0.0);
        } else if (r.is_array() && r.size() == 2) {
            out.emplace_back(number(r[0], index_path(p, 0)), number(r[1], index_path(p, 1)));
        } else {
            fail(p, "must be [re, im] or a real number");
        }
    }
    // Complex roots of a real model come in conjugate pairs.
    canonical_roots(out, path.c_str());
    return out;
}

bool is_doc_key(const std::string& k) {
    return k == "name" || k == "description" || k == "source" || k == "comment" || k == "units" ||
           (!k.empty() && k[0] == '_');
}

Zpk parse(const json& j, const std::string& path, std::optional<double> inherited_ts) {
    if (!j.is_object()) fail(path, "must be an object with num/den, zeros/poles/gain or series");
    for (const auto& [key, value] : j.items()) {
        (void)value;
        if (key == "num" || key == "den" || key == "zeros" || key == "poles" || key == "gain" || key == "series" ||
            key == "ts" || is_doc_key(key))
            continue;
        fail(cat(path, ".", key),
             "unknown field (expected num/den, zeros/poles/gain or series, optional ts, and name, description, "
             "source, comment, units)");
    }
    const bool tf_form = j.contains("num") || j.contains("den");
    const bool zpk_form = j.contains("zeros") || j.contains("poles") || j.contains("gain");
    const bool series_form = j.contains("series");
    if (int(tf_form) + int(zpk_form) + int(series_form) != 1)
        fail(path, "give exactly one of: num and den; zeros, poles and gain; series");

    double ts = 0.0;
    if (j.contains("ts")) {
        ts = number(j["ts"], cat(path, ".ts"));
        if (!(ts > 0.0)) fail(cat(path, ".ts"), "must be > 0 (seconds); omit it for a continuous model");
        if (inherited_ts && *inherited_ts != ts)
            fail(cat(path, ".ts"), cat("is ", fmt(ts, 17), " but the enclosing series has ts ", fmt(*inherited_ts, 17),
                                       " (a series of mixed ts)"));
    } else if (inherited_ts) {
        ts = *inherited_ts;
    }

    if (tf_form) {
        if (!j.contains("num")) fail(path, "has den but no num");
        if (!j.contains("den")) fail(path, "has num but no den");
        Tf tf;
        tf.num = coefficients(j["num"], cat(path, ".num"));
        tf.den = coefficients(j["den"], cat(path, ".den"));
        tf.ts = ts;
        if (tf.den[0] == 0.0) fail(cat(path, ".den[0]"), "leading coefficient must be non-zero");
        return tf2zpk(tf);
    }
    if (zpk_form) {
        for (const char* k : {"zeros", "poles", "gain"})
            if (!j.contains(k)) fail(path, cat("zero-pole-gain form needs \"", k, "\" (use [] for none)"));
        Zpk z;
        z.zeros = canonical_roots(roots(j["zeros"], cat(path, ".zeros")), "zeros");
        z.poles = canonical_roots(roots(j["poles"], cat(path, ".poles")), "poles");
        z.gain = number(j["gain"], cat(path, ".gain"));
        z.ts = ts;
        return z;
    }
    const json& s = j["series"];
    const std::string sp = cat(path, ".series");
    if (!s.is_array()) fail(sp, "must be an array of models");
    if (s.empty()) fail(sp, "must not be empty");
    // Members inherit the series' ts (its own, or the one it inherited);
    // otherwise they must agree with each other.
    std::optional<double> member_ts;
    if (j.contains("ts") || inherited_ts) member_ts = ts;
    std::vector<Zpk> parts;
    for (size_t i = 0; i < s.size(); ++i) parts.push_back(parse(s[i], index_path(sp, i), member_ts));
    for (size_t i = 1; i < parts.size(); ++i)
        if (parts[i].ts != parts[0].ts)
            fail(cat(index_path(sp, i), ".ts"), cat("is ", fmt(parts[i].ts, 17), " but ", index_path(sp, 0),
                                                    " has ts ", fmt(parts[0].ts, 17), " (a series of mixed ts)"));
    Zpk out = series(parts);
    out.zeros = canonical_roots(out.zeros, "zeros");
    out.poles = canonical_roots(out.poles, "poles");
    return out;
}

json root_json(const std::vector<cplx>& roots) {
    json a = json::array();
    for (const cplx& r : roots) a.push_back(json::array({r.real(), r.imag()}));
    return a;
}

}  // namespace

Zpk parse_model(const json& j, const std::string& path, const ModelParseOptions& opt) {
    Zpk z = parse(j, path, std::nullopt);
    if (!opt.allow_improper && z.zeros.size() > z.poles.size())
        fail(path, cat("improper model: ", std::to_string(z.zeros.size()), " zeros but only ",
                       std::to_string(z.poles.size()), " poles (numerator degree above denominator degree)"));
    return z;
}

Zpk load_model_file(const std::string& filename, const ModelParseOptions& opt) {
    std::ifstream f(filename);
    if (!f) throw std::invalid_argument(cat(filename, ": cannot open the model file"));
    std::stringstream buf;
    buf << f.rdbuf();
    json j;
    try {
        j = json::parse(buf.str());
    } catch (const json::exception& e) {  // parse errors, numbers out of double range
        throw std::invalid_argument(cat(filename, ": not valid JSON: ", e.what()));
    }
    try {
        return parse_model(j, "model", opt);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(cat(filename, ": ", e.what()));
    }
}

json to_json(const Zpk& zpk) {
    json j;
    j["zeros"] = root_json(zpk.zeros);
    j["poles"] = root_json(zpk.poles);
    j["gain"] = zpk.gain;
    if (is_discrete(zpk.ts)) j["ts"] = zpk.ts;
    return j;
}

json to_json(const Tf& tf) {
    json j;
    j["num"] = tf.num;
    j["den"] = tf.den;
    if (is_discrete(tf.ts)) j["ts"] = tf.ts;
    return j;
}

}  // namespace piezoloop::design
