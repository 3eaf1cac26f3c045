// The extension module _piezoloop: the host library's simulator, design
// tools and link client for the Python package piezoloop (python/piezoloop),
// which wraps these functions in its documented API.
#include "bindings.hpp"

#include "link/client.hpp"
#include "link/transport.hpp"

PYBIND11_MODULE(_piezoloop, m) {
    namespace pyb = pybind11;
    m.doc() = "piezoloop host library bindings (use the piezoloop package, not this module)";
    // DeviceError derives from LinkError in C++ and in Python; pybind11 tries
    // the translators newest first, so the derived one is registered last.
    static pyb::exception<piezoloop::hostlink::LinkError> link_error(m, "LinkError");
    static pyb::exception<piezoloop::hostlink::DeviceError> device_error(m, "DeviceError", link_error.ptr());
    pyb::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const piezoloop::hostlink::DeviceError& e) {
            device_error(e.what());
        } catch (const piezoloop::hostlink::LinkError& e) {
            link_error(e.what());
        }
    });
    piezoloop::py::add_sim(m);
    piezoloop::py::add_design(m);
    piezoloop::py::add_device(m);
    piezoloop::py::add_measure(m);
    piezoloop::py::add_measure_mimo(m);
    piezoloop::py::add_scan(m);
}
