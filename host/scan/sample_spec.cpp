#include "scan/sample_spec.hpp"

#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace piezoloop::scan {
namespace {

[[noreturn]] void refuse(const std::string& what) { throw std::invalid_argument(what); }

double number(const std::string& key, const std::string& text) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v))
        refuse("'" + key + "' must be a finite number, got '" + text + "'");
    return v;
}

void in_range(const std::string& key, double v, double lo, double hi, bool lo_open, bool hi_open) {
    const bool ok = (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
    if (!ok)
        refuse("'" + key + "' must be in " + (lo_open ? "(" : "[") + std::to_string(lo) + ", " + std::to_string(hi) +
               (hi_open ? ")" : "]"));
}

}  // namespace

SampleSurface parse_sample_spec(const std::string& spec) {
    SampleSurface s;
    const std::size_t colon = spec.find(':');
    const std::string kind = spec.substr(0, colon);
    if (kind == "grating") s.kind = SurfaceKind::kGrating;
    else if (kind == "step") s.kind = SurfaceKind::kStep;
    else if (kind == "dots") {
        s.kind = SurfaceKind::kDots;
        s.height_nm = 20.0;
    } else refuse("the kind must be grating, step or dots, got '" + kind + "'");

    std::string rest = colon == std::string::npos ? std::string() : spec.substr(colon + 1);
    while (!rest.empty()) {
        const std::size_t comma = rest.find(',');
        const std::string item = rest.substr(0, comma);
        rest = comma == std::string::npos ? std::string() : rest.substr(comma + 1);
        const std::size_t eq = item.find('=');
        if (eq == std::string::npos) refuse("'" + item + "' must be key=value");
        const std::string key = item.substr(0, eq);
        const double v = number(key, item.substr(eq + 1));
        if (key == "height_nm") s.height_nm = v;
        else if ((key == "pitch" || key == "pitch_um") && s.kind != SurfaceKind::kStep) s.pitch_um = v;
        else if (key == "duty" && s.kind == SurfaceKind::kGrating) s.duty = v;
        else if ((key == "x" || key == "x_um") && s.kind == SurfaceKind::kStep) s.x_um = v;
        else if ((key == "radius" || key == "radius_um") && s.kind == SurfaceKind::kDots) s.radius_um = v;
        else refuse("'" + key + "' is not a key of " + kind +
                    (s.kind == SurfaceKind::kGrating ? " (pitch, height_nm, duty)"
                     : s.kind == SurfaceKind::kStep  ? " (x, height_nm)"
                                                     : " (pitch, radius, height_nm)"));
    }
    in_range("height_nm", s.height_nm, 0.0, 1e6, true, false);
    in_range("pitch", s.pitch_um, 0.0, 1e4, true, false);
    in_range("duty", s.duty, 0.0, 1.0, true, true);
    in_range("x", s.x_um, -1e6, 1e6, false, false);
    if (s.kind == SurfaceKind::kDots) in_range("radius", s.radius_um, 0.0, s.pitch_um / 2.0, true, true);
    return s;
}

}  // namespace piezoloop::scan
