// Numbers as text, one way for the whole host side: messages, JSON helpers,
// CSV cells, report tables and hashes all format through these.
#pragma once

#include <cmath>
#include <cstdint>
#include <complex>
#include <cstdio>
#include <string>

namespace piezoloop::format {

// `digits` significant digits as printf's %g (exponent when needed): 6 for
// messages, 9 to round-trip a float (CSV cells), 17 to round-trip a double.
inline std::string significant(double v, int digits = 6) {
    char buf[48];
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    return buf;
}

// A complex number as "re + imj" (or "re - imj"), each part with `digits`
// significant digits.
inline std::string complex_significant(std::complex<double> z, int digits) {
    return significant(z.real(), digits) + (z.imag() < 0 ? " - " : " + ") + significant(std::fabs(z.imag()), digits) + "j";
}

// The double nearest `v` written with `digits` significant digits: a float
// printed as 0.38, not 0.37999999523162842, when it goes into JSON.
inline double rounded(double v, int digits) { return std::stod(significant(v, digits)); }

// A table cell with `decimals` after the point; "–" when not finite.
inline std::string fixed(double v, int decimals) {
    if (!std::isfinite(v)) return "–";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    return buf;
}

// A table cell with `digits` significant digits, in plain notation from
// 1e-3 to 1e6 (0.0123, 45.6, 1500), %g outside; "–" when not finite.
inline std::string plain(double v, int digits = 3) {
    if (!std::isfinite(v)) return "–";
    if (v == 0.0) return "0";
    const double a = std::fabs(v);
    if (a >= 1e-3 && a < 1e6) {
        const int magnitude = static_cast<int>(std::floor(std::log10(a)));
        return fixed(v, digits - 1 - magnitude > 0 ? digits - 1 - magnitude : 0);
    }
    return significant(v, digits);
}

// A 64-bit hash as 16 hex digits.
inline std::string hex64(uint64_t h) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
    return buf;
}

}  // namespace piezoloop::format
