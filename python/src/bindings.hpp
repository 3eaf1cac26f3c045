// Shared by the binding files of _piezoloop: each adds its functions to the
// module, and JSON crosses to Python through json.loads of the dumped text
// (the same JSON the command line prints, with no second converter to keep
// in step).
#pragma once

#include <pybind11/pybind11.h>

#include <nlohmann/json.hpp>

namespace piezoloop::py {

namespace pyb = pybind11;

inline pyb::object to_python(const nlohmann::json& j) {
    return pyb::module_::import("json").attr("loads")(j.dump());
}

void add_sim(pyb::module_& m);
void add_design(pyb::module_& m);
void add_device(pyb::module_& m);

}  // namespace piezoloop::py
