#include "measure/frf_file.hpp"

#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "format/number.hpp"

namespace piezoloop::measure {

using nlohmann::json;

namespace {

[[noreturn]] void bad(const std::string& file, const std::string& field, const std::string& why) {
    throw std::invalid_argument(file + ": " + field + ": " + why);
}

}  // namespace

FrfData load_frf_file(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::invalid_argument("--frf: cannot read " + path);
    json j;
    try {
        j = json::parse(in);
    } catch (const json::exception& e) {
        throw std::invalid_argument(path + ": not JSON: " + e.what());
    }
    if (!j.is_object()) bad(path, "(top)", "must be an object (measure frf's output)");
    auto array_of = [&](const char* key) {
        if (!j.contains(key) || !j[key].is_array()) bad(path, key, "missing or not an array");
        return j[key];
    };
    const json f = array_of("frequency_Hz"), r = array_of("response");
    if (f.size() != r.size()) bad(path, "response", "must have one [re, im] pair per frequency");
    if (!j.contains("excitation") || !j["excitation"].is_object() || !j["excitation"].contains("rate_Hz") ||
        !j["excitation"]["rate_Hz"].is_number())
        bad(path, "excitation.rate_Hz", "missing: the loop rate the response was measured at");
    FrfData d;
    d.rate_Hz = j["excitation"]["rate_Hz"].get<double>();
    if (!(d.rate_Hz > 0.0) || !std::isfinite(d.rate_Hz)) bad(path, "excitation.rate_Hz", "must be > 0");
    // Each line once, between 0 and Nyquist: a line measured twice with two
    // responses has no single value to fit.
    std::map<double, std::size_t> seen;
    for (std::size_t i = 0; i < f.size(); ++i) {
        const std::string fi = "frequency_Hz[" + std::to_string(i) + "]";
        if (!f[i].is_number()) bad(path, fi, "must be a number");
        const double f_Hz = f[i].get<double>();
        if (!(f_Hz > 0.0 && f_Hz <= d.rate_Hz / 2.0))
            bad(path, fi, "must be in (0, " + format::significant(d.rate_Hz / 2.0) + "] Hz, the Nyquist frequency of "
                          "excitation.rate_Hz (got " + format::significant(f_Hz) + ")");
        const auto [it, fresh] = seen.emplace(f_Hz, i);
        if (!fresh)
            bad(path, fi, format::significant(f_Hz, 10) + " Hz is frequency_Hz[" + std::to_string(it->second) +
                              "] again: each line once");
        // Lines within 1e-9 of each other are one line measured twice: no
        // measurement resolves them (a multisine's lines are rate / N apart).
        for (const auto other : {std::next(it), it == seen.begin() ? seen.end() : std::prev(it)})
            if (other != seen.end() && std::fabs(other->first - f_Hz) <= 1e-9 * f_Hz)
                bad(path, fi, format::significant(f_Hz, 17) + " Hz is within 1e-9 of frequency_Hz[" +
                                  std::to_string(other->second) + "] (" + format::significant(other->first, 17) +
                                  " Hz): the same line again; each line once");
        const std::string ri = "response[" + std::to_string(i) + "]";
        if (!r[i].is_array() || r[i].size() != 2 || !r[i][0].is_number() || !r[i][1].is_number())
            bad(path, ri, "must be [re, im]");
        const design::cplx g(r[i][0].get<double>(), r[i][1].get<double>());
        if (!std::isfinite(g.real()) || !std::isfinite(g.imag())) bad(path, ri, "must be finite");
        d.f_Hz.push_back(f_Hz);
        d.response.push_back(g);
    }
    if (j.contains("std_db")) {
        const json s = array_of("std_db");
        if (s.size() != f.size()) bad(path, "std_db", "must have one entry per frequency");
        for (std::size_t i = 0; i < s.size(); ++i) {
            // null: unknown (a single period has no spread).
            if (s[i].is_null()) {
                d.std_db.push_back(std::nan(""));
                continue;
            }
            const double x = s[i].is_number() ? s[i].get<double>() : -1.0;
            if (!(x >= 0.0) || !std::isfinite(x))
                bad(path, "std_db[" + std::to_string(i) + "]",
                    "must be a finite number >= 0 dB (one standard deviation of |G|) or null (unknown)");
            d.std_db.push_back(x);
        }
    }
    return d;
}

}  // namespace piezoloop::measure
