// The simulator's use of the design toolkit: model files (lti/model_json),
// c2d (lti/c2d), the SOS split (lti/sos) and state space
// (lti/lti_convert).
#include "sim/design_bridge.hpp"

#include <cmath>
#include <optional>
#include <stdexcept>

#include "lti/c2d.hpp"
#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"
#include "lti/model_json.hpp"
#include "lti/sos.hpp"

namespace piezoloop::sim {

LinearSpec read_linear_model(const Field& f, const std::filesystem::path& base_dir) {
    LinearSpec s;
    s.path = f.path();
    if (f.is_string()) {
        const std::filesystem::path p = base_dir / f.string();
        try {
            s.zpk = design::load_model_file(p.string());
        } catch (const std::exception& e) {
            f.fail(e.what());
        }
        s.source = f.string();
    } else {
        try {
            s.zpk = design::parse_model(f.json(), f.path());
        } catch (const std::exception& e) {
            throw ScenarioError(e.what());  // names the path already
        }
        s.source = "inline";
    }
    return s;
}

design::Zpk normalise_dc_gain(const design::Zpk& zpk, const Field& f) {
    const double g = design::dc_gain(zpk);
    if (!std::isfinite(g) || g == 0.0) f.fail("cannot normalise the DC gain: the model has a pole or zero at DC");
    design::Zpk z = zpk;
    z.gain /= g;
    return z;
}

design::Zpk discretise(const design::Zpk& zpk, double rate_Hz, const std::string& method, double prewarp_Hz,
                       bool advance, const std::string& what) {
    try {
        design::Zpk d = design::c2d(zpk, 1.0 / rate_Hz, design::parse_c2d_method(method), 2.0 * M_PI * prewarp_Hz);
        // y[k+1] from u[k]: one zero at z = 0 more.
        if (advance) d.zeros.push_back({0.0, 0.0});
        return d;
    } catch (const std::exception& e) {
        throw std::invalid_argument(what + ": " + e.what());
    }
}

std::vector<SosSection> discretise_sos(const design::Zpk& zpk, double rate_Hz, const std::string& method,
                                       double prewarp_Hz, bool advance, const std::string& what,
                                       size_t max_sections) {
    const design::Zpk d = discretise(zpk, rate_Hz, method, prewarp_Hz, advance, what);
    std::vector<SosSection> sos;
    try {
        // A real pole within 1e-3 of z = 1 (an integrator-like pole, e.g.
        // C(s)'s s = -1 at 100 kHz) gets a first-order section of its own,
        // with the nearest real zero: paired with another real pole, as
        // scipy's pairing does, 1 + a1 + a2 becomes too small for float32
        // coefficients to resolve. The rest is split by the toolkit.
        design::Zpk rest = d;
        std::optional<SosSection> slow;
        int pi = -1;
        for (size_t i = 0; i < rest.poles.size(); ++i)
            if (rest.poles[i].imag() == 0.0 && std::fabs(1.0 - rest.poles[i].real()) < 1e-3 &&
                (pi < 0 || rest.poles[i].real() > rest.poles[static_cast<size_t>(pi)].real()))
                pi = static_cast<int>(i);
        if (pi >= 0 && rest.poles.size() % 2 == 1) {
            const double p = rest.poles[static_cast<size_t>(pi)].real();
            rest.poles.erase(rest.poles.begin() + pi);
            int zi = -1;
            for (size_t i = 0; i < rest.zeros.size(); ++i)
                if (rest.zeros[i].imag() == 0.0 &&
                    (zi < 0 || std::fabs(rest.zeros[i].real() - p) <
                                   std::fabs(rest.zeros[static_cast<size_t>(zi)].real() - p)))
                    zi = static_cast<int>(i);
            if (zi >= 0) {
                const double z = rest.zeros[static_cast<size_t>(zi)].real();
                rest.zeros.erase(rest.zeros.begin() + zi);
                slow = SosSection{1.0, -z, 0.0, -p, 0.0};
            } else {
                slow = SosSection{0.0, 1.0, 0.0, -p, 0.0};
            }
        }
        sos = rest.poles.empty() && slow ? std::vector<SosSection>{} : design::zpk2sos(rest);
        if (slow) {
            if (sos.empty()) {
                slow->b0 *= rest.gain;
                slow->b1 *= rest.gain;
                slow->b2 *= rest.gain;
            }
            sos.push_back(*slow);  // nearest the unit circle: last
        }
    } catch (const std::exception& e) {
        throw std::invalid_argument(what + ": " + e.what());
    }
    if (sos.size() > max_sections)
        throw std::invalid_argument(what + ": " + std::to_string(sos.size()) + " biquad sections, at most " +
                                    std::to_string(max_sections) + " fit here");
    return sos;
}

std::vector<SosSection> controller_sos(const design::Zpk& zpk, double rate_Hz, const std::string& method,
                                       double prewarp_Hz, bool q31, double in_full_scale, double out_full_scale,
                                       const std::string& what, size_t max_sections) {
    std::vector<SosSection> sos = discretise_sos(zpk, rate_Hz, method, prewarp_Hz, false, what, max_sections);
    if (q31) {
        design::SosScaling sc;
        sc.norm = design::SosNorm::kL1;
        sc.in_full_scale = in_full_scale;
        sc.out_full_scale = out_full_scale;
        sos = design::scale_sos(sos, sc);
    }
    return sos;
}

design::Ss state_space(const design::Zpk& zpk) { return design::balance(design::zpk2ss(zpk)); }

}  // namespace piezoloop::sim
