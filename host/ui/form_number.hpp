// A number field of one of the console's forms: its value, or a refusal at
// that field when it holds anything else.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "ui/field_refusal.hpp"

namespace piezoloop::ui {

inline double form_number(const nlohmann::json& v, const std::string& field) {
    if (!v.is_number()) throw FieldRefusal(field, field + ": must be a number");
    return v.get<double>();
}

}  // namespace piezoloop::ui
