// LTI models as JSON files, the form users write them in:
//
//   {"num": [b_m, …, b_0], "den": [a_n, …, a_0]}        descending powers
//   {"zeros": [[re, im], …], "poles": [[re, im], …], "gain": k}
//                                    (a bare number is a real root)
//   {"series": [model, model, …]}   product of models (factored forms)
//
// Optional in every model: "ts" (seconds, > 0) makes it discrete (z
// instead of s); a series member without "ts" takes the series' ts, and
// members with different ts are an error. Documentation fields "name",
// "description", "source", "comment", "units" and any key starting with
// "_" are ignored; any other key is an error (catches typos).
//
// The result is always a Zpk (factored form: roots of num/den via
// tf2zpk, members of a series concatenated), so nothing of high order is
// ever multiplied out. Errors throw std::invalid_argument with the field's
// path and what is wrong, e.g.
//   "model.series[1].den[0]: leading coefficient must be non-zero".
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "lti/lti.hpp"

namespace piezoloop::design {

struct ModelParseOptions {
    // The top-level model must be proper (#zeros <= #poles) unless this is
    // set; members of a series may be improper on their own.
    bool allow_improper = false;
};

Zpk parse_model(const nlohmann::json& j, const std::string& path = "model", const ModelParseOptions& opt = {});

// Reads and parses a model file. Errors are prefixed with the file name:
// "M.json: model.den[0]: …"; unreadable files and invalid JSON are errors too.
Zpk load_model_file(const std::string& filename, const ModelParseOptions& opt = {});

// Writing models back: Zpk as {"zeros", "poles", "gain"[, "ts"]} with
// complex roots as [re, im]; Tf as {"num", "den"[, "ts"]}.
nlohmann::json to_json(const Zpk& zpk);
nlohmann::json to_json(const Tf& tf);

}  // namespace piezoloop::design
