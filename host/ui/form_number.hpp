// Number fields of the console's forms: their value, or a refusal at the
// field when it holds anything else.
#pragma once

#include <nlohmann/json.hpp>

#include <cmath>
#include <string>

#include "ui/field_refusal.hpp"

namespace piezoloop::ui {

inline double form_number(const nlohmann::json& v, const std::string& field) {
    if (!v.is_number()) throw FieldRefusal(field, field + ": must be a number");
    return v.get<double>();
}

// A whole number of at most max_abs in magnitude.
inline int form_whole(const nlohmann::json& v, const std::string& field, double max_abs) {
    const double x = form_number(v, field);
    if (x != std::floor(x) || std::abs(x) > max_abs) throw FieldRefusal(field, field + ": must be a whole number");
    return static_cast<int>(x);
}

}  // namespace piezoloop::ui
