#include "measure/frf_file.hpp"

#include <cmath>
#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

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
    FrfData d;
    for (std::size_t i = 0; i < f.size(); ++i) {
        if (!f[i].is_number()) bad(path, "frequency_Hz[" + std::to_string(i) + "]", "must be a number");
        if (!r[i].is_array() || r[i].size() != 2 || !r[i][0].is_number() || !r[i][1].is_number())
            bad(path, "response[" + std::to_string(i) + "]", "must be [re, im]");
        d.f_Hz.push_back(f[i].get<double>());
        d.response.emplace_back(r[i][0].get<double>(), r[i][1].get<double>());
    }
    if (j.contains("std_db")) {
        const json s = array_of("std_db");
        if (s.size() != f.size()) bad(path, "std_db", "must have one entry per frequency");
        for (const json& x : s) d.std_db.push_back(x.is_number() ? x.get<double>() : std::nan(""));
    }
    if (!j.contains("excitation") || !j["excitation"].contains("rate_Hz") || !j["excitation"]["rate_Hz"].is_number())
        bad(path, "excitation.rate_Hz", "missing: the loop rate the response was measured at");
    d.rate_Hz = j["excitation"]["rate_Hz"].get<double>();
    if (!(d.rate_Hz > 0.0) || !std::isfinite(d.rate_Hz)) bad(path, "excitation.rate_Hz", "must be > 0");
    return d;
}

}  // namespace piezoloop::measure
