#include "lti/model_json.hpp"
#include "lti/text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "format/number.hpp"
#include "json/json_reader.hpp"
#include "lti/lti_convert.hpp"

namespace piezoloop::design {
namespace {

using nlohmann::json;
using hostjson::Field;

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    throw std::invalid_argument(cat(path, ": ", what));
}

std::vector<double> coefficients(const Field& f) {
    if (!f.is_array()) f.fail("must be an array of numbers (descending powers)");
    if (f.size() == 0) f.fail("must not be empty");
    if (f.size() > kMaxModelOrder + 1)
        f.fail(cat("at most ", std::to_string(kMaxModelOrder + 1), " coefficients (order ",
                   std::to_string(kMaxModelOrder), "), got ", std::to_string(f.size())));
    return f.numbers();
}

std::vector<cplx> roots(const Field& f) {
    if (!f.is_array()) f.fail("must be an array of roots, each [re, im] or a real number");
    if (f.size() > kMaxModelOrder)
        f.fail(cat("at most ", std::to_string(kMaxModelOrder), " roots, got ", std::to_string(f.size())));
    std::vector<cplx> out;
    for (size_t i = 0; i < f.size(); ++i) {
        const Field r = f.at(i);
        if (r.is_number()) {
            out.emplace_back(r.number(), 0.0);
        } else if (r.is_array() && r.size() == 2) {
            out.emplace_back(r.at(0).number(), r.at(1).number());
        } else {
            r.fail("must be [re, im] or a real number");
        }
    }
    // Complex roots of a real model come in conjugate pairs.
    canonical_roots(out, f.path().c_str());
    return out;
}

bool is_doc_key(const std::string& k) {
    return k == "name" || k == "description" || k == "source" || k == "comment" || k == "units" ||
           (!k.empty() && k[0] == '_');
}

// depth: series within series so far (bounded: each level recurses).
Zpk parse(const Field& f, std::optional<double> inherited_ts, int depth) {
    const json& j = f.json();
    const std::string& path = f.path();
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
        ts = f["ts"].number();
        if (!(ts > 0.0)) fail(cat(path, ".ts"), "must be > 0 (seconds); omit it for a continuous model");
        if (inherited_ts && *inherited_ts != ts)
            fail(cat(path, ".ts"), cat("is ", format::significant(ts, 17), " but the enclosing series has ts ",
                                       format::significant(*inherited_ts, 17), " (a series of mixed ts)"));
    } else if (inherited_ts) {
        ts = *inherited_ts;
    }

    if (tf_form) {
        if (!j.contains("num")) fail(path, "has den but no num");
        if (!j.contains("den")) fail(path, "has num but no den");
        Tf tf;
        tf.num = coefficients(f["num"]);
        tf.den = coefficients(f["den"]);
        tf.ts = ts;
        if (tf.den[0] == 0.0) fail(cat(path, ".den[0]"), "leading coefficient must be non-zero");
        return tf2zpk(tf);
    }
    if (zpk_form) {
        for (const char* k : {"zeros", "poles", "gain"})
            if (!j.contains(k)) fail(path, cat("zero-pole-gain form needs \"", k, "\" (use [] for none)"));
        Zpk z;
        z.zeros = canonical_roots(roots(f["zeros"]), "zeros");
        z.poles = canonical_roots(roots(f["poles"]), "poles");
        z.gain = f["gain"].number();
        z.ts = ts;
        return z;
    }
    const Field s = f["series"];
    const std::string& sp = s.path();
    if (!s.is_array()) fail(sp, "must be an array of models");
    if (s.size() == 0) fail(sp, "must not be empty");
    if (depth >= kMaxModelNesting)
        fail(sp, cat("series nested deeper than ", std::to_string(kMaxModelNesting), " levels"));
    // Members inherit the series' ts (its own, or the one it inherited);
    // otherwise they must agree with each other.
    std::optional<double> member_ts;
    if (j.contains("ts") || inherited_ts) member_ts = ts;
    std::vector<Zpk> parts;
    std::size_t order = 0;
    for (size_t i = 0; i < s.size(); ++i) {
        parts.push_back(parse(s.at(i), member_ts, depth + 1));
        order += std::max(parts.back().zeros.size(), parts.back().poles.size());
        if (order > kMaxModelOrder)
            s.at(i).fail(cat("the series reaches order ", std::to_string(order), ", above the ",
                             std::to_string(kMaxModelOrder), " a model may have"));
    }
    for (size_t i = 1; i < parts.size(); ++i)
        if (parts[i].ts != parts[0].ts)
            fail(cat(s.at(i).path(), ".ts"), cat("is ", format::significant(parts[i].ts, 17), " but ", s.at(0).path(),
                                                 " has ts ", format::significant(parts[0].ts, 17), " (a series of mixed ts)"));
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
    Zpk z = parse(Field(j, path), std::nullopt, 0);
    if (!opt.allow_improper && z.zeros.size() > z.poles.size())
        fail(path, cat("improper model: ", std::to_string(z.zeros.size()), " zeros but only ",
                       std::to_string(z.poles.size()), " poles (numerator degree above denominator degree)"));
    return z;
}

Zpk load_model_file(const std::string& filename, const ModelParseOptions& opt) {
    if (!std::ifstream(filename)) throw std::invalid_argument(cat(filename, ": cannot open the model file"));
    json j;
    try {
        // Bounded: a model file is a few hundred bytes; 1 MiB and 32
        // levels of nesting leave room for any real one.
        j = hostjson::read_file(filename, {std::size_t{1} << 20, 2 * kMaxModelNesting + 4});
    } catch (const hostjson::JsonError& e) {
        const std::string m = e.what();
        if (m.rfind(filename, 0) == 0) throw;  // names the file already
        throw std::invalid_argument(cat(filename, ": model.", m));
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
