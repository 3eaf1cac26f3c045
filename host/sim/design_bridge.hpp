// What the simulator takes from the design toolkit (host/lti/, host/analysis/): reading
// model files, discretising continuous models to biquad sections at the loop
// rate, and state-space realisations for the double-fidelity stage. Kept in
// one place so the scenario code does not depend on the toolkit's file
// layout.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "lti/lti.hpp"
#include "piezoloop/biquad.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::sim {

// A model given as a file name (relative to base_dir) or inline, in the
// toolkit's JSON model format. Errors name the field path.
LinearSpec read_linear_model(const Field& f, const std::filesystem::path& base_dir);

// The model scaled to a DC gain of 1 (fails, naming f, for a pole or zero at DC).
design::Zpk normalise_dc_gain(const design::Zpk& zpk, const Field& f);

// Continuous model -> discrete at rate_Hz (advance: times z).
design::Zpk discretise(const design::Zpk& zpk, double rate_Hz, const std::string& method, double prewarp_Hz,
                       bool advance, const std::string& what);

// Continuous model -> second-order sections at rate_Hz.
//   method "zoh":    exact for a held input; with `advance` the result is
//                    multiplied by z (y[k+1] from u[k]: the plant step of the
//                    float stage, see closed_loop.hpp).
//   method "tustin": bilinear, pre-warped at prewarp_Hz when > 0.
//   method "matched": matched pole-zero.
std::vector<SosSection> discretise_sos(const design::Zpk& zpk, double rate_Hz, const std::string& method,
                                       double prewarp_Hz, bool advance, const std::string& what,
                                       size_t max_sections);

// A continuous controller (or reference pre-filter) as the core's sections
// at rate_Hz. For a Q31 core the gain is spread (lti/sos, L1 scaling) so
// that no internal node can overflow for a full-scale input: in_full_scale
// is the input's (µm), out_full_scale the output's. More than max_sections
// fails (std::invalid_argument naming `what`).
std::vector<SosSection> controller_sos(const design::Zpk& zpk, double rate_Hz, const std::string& method,
                                       double prewarp_Hz, bool q31, double in_full_scale, double out_full_scale,
                                       const std::string& what, size_t max_sections = kMaxControllerSections);

// Continuous state-space realisation (balanced, real blocks).
design::Ss state_space(const design::Zpk& zpk);

}  // namespace piezoloop::sim
