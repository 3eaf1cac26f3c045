// Realisation check: does a biquad cascade, run by the core's own classes
// (common/piezoloop/biquad.hpp: float32 DF2T or delta-operator sections,
// chosen per section by the cascade, or Q31 DF1 relative to z = 1 with error
// feedback), do what the double-precision design says, at its rate? The
// report names each section's form (section_forms).
//
//  * configure(): the core's own validation (Status) of the sections and
//    full scales, reported as "field: message" when it rejects.
//  * Frequency response, measured: the cascade object is fed a single
//    impulse (full scale for float, half full scale for Q31) and its output
//    is recorded until the slowest pole (design or realised) has decayed to
//    1e-12; the DFT of that impulse response at 61 log-spaced frequencies
//    from 0.01 Hz up to 0.999 Nyquist is compared with the
//    design's response: error in dB (20 log10 |H_real / H_design|) and in
//    phase (degrees). Points where the design's gain in sample units is
//    below the realisation's noise floor (Q31: output rounding accumulated
//    over the record) are listed but not counted.
//  * Pole displacement: the poles of the coefficients as the core
//    quantises them (float DF2T: a1, a2 rounded to float; float delta:
//    2 + a1 and 1 + a1 + a2 rounded to float; Q31:
//    the mantissas of a1 + 2 and a2 - 1 on their block exponent, as
//    BiquadCascade<Q31> computes them) against the double design, as |dz| and relative to the
//    pole's distance 1 - |z| to the unit circle.
//  * Verdict: unfit if configure() rejects, if any pole moves by more than
//    max_pole_shift of its distance to the unit circle, or if the response
//    error exceeds max_error_db / max_phase_error_deg; each reason is a
//    warning sentence. Both forms hold the sources' controllers at 10 to
//    100 kHz (Ahmad2020 K(s): slow pole pair at |z| ~ 0.99997 at 100 kHz);
//    poles near the unit circle away from z = 1 (e.g. a2 = 1 - 1e-9) are
//    refused by both.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lti/lti.hpp"
#include "piezoloop/biquad.hpp"

namespace piezoloop::design {

enum class SampleFormat { kFloat, kQ31 };
SampleFormat parse_sample_format(const std::string& name);  // "float" | "q31"
const char* sample_format_name(SampleFormat f);
// The section structure the core uses, for reports (float: per section,
// BiquadCascade<float>::form; Q31: one form).
const char* section_form_name(SampleFormat f, SectionForm form);

// Largest cascade the check (and the command line) handles.
inline constexpr int kMaxCheckedSections = 32;

struct RealisationOptions {
    SampleFormat format = SampleFormat::kQ31;
    double in_full_scale = 1.0;   // physical units per Q31 full scale
    double out_full_scale = 1.0;
    int frequencies = 61;
    double f_min_hz = 0.01;  // lowest frequency checked (the highest is 0.999 Nyquist)
    long max_samples = 8'000'000;  // impulse record cap
    double max_error_db = 0.1;
    double max_phase_error_deg = 1.0;
    double max_pole_shift = 0.01;  // of 1 - |z|
};

struct PoleShift {
    int section = 0;
    cplx design;
    cplx realised;
    double shift = 0.0;           // |dz|
    double relative_shift = 0.0;  // |dz| / (1 - |z_design|)
};

struct ResponsePoint {
    double f_hz = 0.0;
    cplx design;
    cplx realised;
    double error_db = 0.0;
    double phase_error_deg = 0.0;
    bool counted = true;  // false: below the realisation's noise floor
};

struct RealisationReport {
    SampleFormat format = SampleFormat::kQ31;
    std::vector<std::string> section_forms;  // the core's structure, per section
    bool configured = false;
    std::string configure_error;  // "sections[2].a1: …" when rejected
    std::vector<PoleShift> poles;
    double max_relative_pole_shift = 0.0;
    std::vector<ResponsePoint> response;
    double max_error_db = 0.0;  // largest |error_db| over counted points
    double max_phase_error_deg = 0.0;
    double worst_f_hz = 0.0;
    long impulse_samples = 0;
    bool fit = false;
    std::vector<std::string> warnings;
};

// design: the discrete double-precision model the sections realise (ts > 0);
// sections: as they will be loaded into the core (scaled).
RealisationReport check_realisation(const Zpk& design, const std::vector<SosSection>& sections,
                                    const RealisationOptions& opt);

nlohmann::json to_json(const RealisationReport& r);

// How much more rounding noise the Q31 cascade puts out than one section
// would: each section's output rounding re-enters as (1 - z^-1)^2 e (error
// feedback) and then passes the sections after it. Returns
// sqrt(sum_i ||(1 - z^-1)^2 H_{i+1} ... H_{m-1}||_2^2 / 6) over n samples:
// 1 for a single section (||(1 - z^-1)^2||^2 = 1 + 4 + 1), large when a
// high-gain section follows others (Ahmad2020 K(s) with its gain of ~500 in
// the last section: the earlier sections' LSB steps come out as a few
// hundred LSB). check_realisation scales its Q31 noise allowance by it.
double q31_noise_amplification(const std::vector<SosSection>& sections, long n);

}  // namespace piezoloop::design
