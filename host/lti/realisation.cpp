#include "lti/realisation.hpp"
#include "lti/text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <stdexcept>

#include "lti/freqresp.hpp"
#include "lti/sos.hpp"
#include "piezoloop/q31.hpp"
#include "status_text.hpp"

namespace piezoloop::design {
namespace {

// The imaginary part of a root with its sign: "+0.5j", "-0.5j".
std::string imaginary(double v, int digits) {
    return (std::signbit(v) ? "" : "+") + format::significant(v, digits) + "j";
}

constexpr int kMax = kMaxCheckedSections;

// The section poles after the core's coefficient quantisation.
std::vector<cplx> realised_poles(const SosSection& s, SampleFormat format, SectionForm form) {
    if (format == SampleFormat::kFloat && form == SectionForm::kDf2t) {
        // a1, a2 rounded to float; a1f + 2 and 1 + a1f + a2f are exact in
        // double (float values of nearby exponents).
        const double a1 = static_cast<float>(s.a1), a2 = static_cast<float>(s.a2);
        const double c1 = a1 + 2.0;
        return section_poles_shifted(c1, c1 + (a2 - 1.0));
    }
    if (format == SampleFormat::kFloat) {
        // Delta form: c1 = 2 + a1 and c0 = 1 + a1 + a2 computed in double,
        // then rounded to float.
        const double c1 = s.a1 + 2.0;
        const double c0 = c1 + (s.a2 - 1.0);
        return section_poles_shifted(static_cast<float>(c1), static_cast<float>(c0));
    }
    // As BiquadCascade<Q31>::configure: c1 = a1 + 2, c2 = a2 - 1 on one
    // block exponent, c2 chosen so that c1 + c2 = 1 + a1 + a2 is best-rounded.
    const double fb[2] = {s.a1 + 2.0, s.a2 - 1.0};
    const int ec = detail::partial_sum_exponent(fb, 2);
    const int64_t n1 = quantize_mantissa(fb[0], ec);
    const int64_t n12 = quantize_mantissa(fb[0] + fb[1], ec);
    const int64_t c2 = std::clamp<int64_t>(n12 - n1, Q31::kMinRaw, Q31::kMaxRaw);
    const double unit = std::ldexp(1.0, ec - 31);
    const double c1q = static_cast<double>(n1) * unit;
    const double c0q = static_cast<double>(n1 + c2) * unit;
    return section_poles_shifted(c1q, c0q);
}

// Peak |node value| of every partial cascade for a unit impulse, in double.
double peak_node_for_impulse(const std::vector<SosSection>& sections, long n) {
    std::vector<SosStateDouble> st(sections.size());
    double peak = 0.0;
    for (long k = 0; k < n; ++k) {
        double x = k == 0 ? 1.0 : 0.0;
        for (size_t i = 0; i < sections.size(); ++i) {
            x = df2t_step(sections[i], st[i], x);
            peak = std::max(peak, std::fabs(x));
        }
    }
    return peak;
}

// sum h[n] e^{-j theta n}, the phasor re-seeded exactly every 1024 samples.
cplx dft_at(const std::vector<double>& h, double theta) {
    cplx acc = 0.0;
    const cplx step = std::polar(1.0, -theta);
    cplx ph = 1.0;
    for (size_t n = 0; n < h.size(); ++n) {
        if ((n & 1023u) == 0) ph = std::polar(1.0, -theta * static_cast<double>(n));
        acc += h[n] * ph;
        ph *= step;
    }
    return acc;
}

}  // namespace

double q31_noise_amplification(const std::vector<SosSection>& sections, long n) {
    double sum = 0.0;
    for (size_t i = 0; i < sections.size(); ++i) {
        std::vector<SosStateDouble> st(sections.size());
        double energy = 0.0;
        for (long k = 0; k < n; ++k) {
            double x = k == 0 ? 1.0 : k == 1 ? -2.0 : k == 2 ? 1.0 : 0.0;  // (1 - z^-1)^2
            for (size_t j = i + 1; j < sections.size(); ++j) x = df2t_step(sections[j], st[j], x);
            energy += x * x;
        }
        sum += energy;
    }
    return std::sqrt(sum / 6.0);
}

SampleFormat parse_sample_format(const std::string& name) {
    if (name == "float") return SampleFormat::kFloat;
    if (name == "q31") return SampleFormat::kQ31;
    throw std::invalid_argument(cat("format: '", name, "' is not one of float, q31"));
}

const char* sample_format_name(SampleFormat f) { return f == SampleFormat::kFloat ? "float" : "q31"; }

const char* section_form_name(SampleFormat f, SectionForm form) {
    if (f == SampleFormat::kQ31) return "Q31 direct form I relative to z = 1 (c1 = a1 + 2, c2 = a2 - 1), error feedback";
    return form == SectionForm::kDf2t
               ? "float32 direct form II transposed"
               : "float32 delta operator (d = z - 1: c1 = 2 + a1, c0 = 1 + a1 + a2), compensated states";
}

RealisationReport check_realisation(const Zpk& design, const std::vector<SosSection>& sections,
                                    const RealisationOptions& opt) {
    if (!is_discrete(design.ts)) throw std::invalid_argument("realisation: the design must be discrete (ts > 0)");
    if (sections.empty()) throw std::invalid_argument("realisation: no sections");
    if (opt.frequencies < 2) throw std::invalid_argument("realisation: frequencies must be >= 2");
    RealisationReport r;
    r.format = opt.format;
    const char* fmt_name = opt.format == SampleFormat::kFloat ? "float32" : "Q31 DF1";
    const double rate = 1.0 / design.ts;

    // 1. The core's own validation, and the form of each section.
    std::vector<SectionForm> forms;  // float only
    if (static_cast<int>(sections.size()) > kMax) {
        r.configure_error = cat("count: ", std::to_string(sections.size()), " sections exceed the checked maximum ",
                                std::to_string(kMax));
    } else {
        const SignalScale in{static_cast<float>(opt.in_full_scale)}, out{static_cast<float>(opt.out_full_scale)};
        Status st;
        if (opt.format == SampleFormat::kFloat) {
            auto c = std::make_unique<BiquadCascade<float, kMax>>();
            st = c->configure(sections.data(), static_cast<int>(sections.size()), in, out);
            for (int i = 0; st.ok() && i < c->count(); ++i) forms.push_back(c->form(i));
        } else {
            auto c = std::make_unique<BiquadCascade<Q31, kMax>>();
            st = c->configure(sections.data(), static_cast<int>(sections.size()), in, out);
        }
        for (size_t i = 0; st.ok() && i < sections.size(); ++i)
            r.section_forms.push_back(section_form_name(opt.format, i < forms.size() ? forms[i] : SectionForm::kDf2t));
        r.configured = st.ok();
        if (!st.ok()) r.configure_error = describe(st);
    }
    if (!r.configured) {
        r.warnings.push_back(cat("the ", fmt_name, " cascade rejects these sections: ", r.configure_error));
        if (opt.format == SampleFormat::kFloat) r.warnings.push_back("try --format q31");
        r.fit = false;
        return r;
    }

    // 2. Pole displacement from coefficient quantisation.
    double rho = 0.0;
    for (size_t i = 0; i < sections.size(); ++i) {
        std::vector<cplx> d = section_poles(sections[i]);
        std::vector<cplx> q =
            realised_poles(sections[i], opt.format, i < forms.size() ? forms[i] : SectionForm::kDf2t);
        for (const cplx& p : q) rho = std::max(rho, std::abs(p));
        for (const cplx& p : d) rho = std::max(rho, std::abs(p));
        // Match each design pole with the nearest realised one.
        if (std::abs(d[0] - q[1]) + std::abs(d[1] - q[0]) < std::abs(d[0] - q[0]) + std::abs(d[1] - q[1]))
            std::swap(q[0], q[1]);
        for (int k = 0; k < 2; ++k) {
            if (sections[i].a2 == 0.0 && d[static_cast<size_t>(k)] == cplx(0.0) &&
                q[static_cast<size_t>(k)] == cplx(0.0))
                continue;  // the padding pole of a first-order section
            PoleShift ps;
            ps.section = static_cast<int>(i);
            ps.design = d[static_cast<size_t>(k)];
            ps.realised = q[static_cast<size_t>(k)];
            ps.shift = std::abs(ps.realised - ps.design);
            const double dist = 1.0 - std::abs(ps.design);
            ps.relative_shift = dist > 0.0 ? ps.shift / dist : std::numeric_limits<double>::infinity();
            r.max_relative_pole_shift = std::max(r.max_relative_pole_shift, ps.relative_shift);
            r.poles.push_back(ps);
        }
    }
    for (const PoleShift& ps : r.poles)
        if (ps.relative_shift > opt.max_pole_shift && ps.design.imag() >= 0.0) {  // one warning per pair
            r.warnings.push_back(cat(
                "section ", std::to_string(ps.section), ": the ", fmt_name, " coefficients move the pole at ",
                format::significant(ps.design.real(), 9), imaginary(ps.design.imag(), 3), " to ",
                format::significant(ps.realised.real(), 9), imaginary(ps.realised.imag(), 3), " (|dz| = ",
                format::significant(ps.shift, 3), ", ", format::significant(100.0 * ps.relative_shift, 3),
                " % of its distance to the unit circle): this realisation is unfit",
                opt.format == SampleFormat::kFloat ? "; use --format q31" : ""));
        }

    // 3. Impulse response of the core's cascade object.
    long n = rho < 1.0 ? static_cast<long>(std::ceil(std::log(1e-12) / std::log(std::max(rho, 1e-300)))) + 64
                       : opt.max_samples;
    n = std::clamp(n, 1024L, opt.max_samples);
    r.impulse_samples = n;
    const double io = opt.in_full_scale / opt.out_full_scale;
    std::vector<double> h(static_cast<size_t>(n));
    double amplitude;  // input impulse, sample units
    double lsb;        // output resolution, sample units
    bool saturated = false;
    if (opt.format == SampleFormat::kFloat) {
        amplitude = opt.in_full_scale;
        auto c = std::make_unique<BiquadCascade<float, kMax>>();
        c->configure(sections.data(), static_cast<int>(sections.size()), {}, {});
        for (long k = 0; k < n; ++k) {
            const float y = c->apply(k == 0 ? static_cast<float>(amplitude) : 0.0f);
            h[static_cast<size_t>(k)] = static_cast<double>(y) / amplitude;
        }
        // float rounding relative to the largest node value
        lsb = std::ldexp(1.0, -24) * peak_node_for_impulse(sections, std::min(n, 200000L)) * amplitude;
    } else {
        // Half full scale, less if a node of the scaled cascade would clip.
        const double peak = peak_node_for_impulse(sections, std::min(n, 200000L)) * io;
        amplitude = std::min(0.5, 0.5 / std::max(peak, 1e-300));
        const Q31 x0 = Q31::from_double(amplitude);
        amplitude = x0.to_double();
        auto c = std::make_unique<BiquadCascade<Q31, kMax>>();
        c->configure(sections.data(), static_cast<int>(sections.size()), SignalScale{static_cast<float>(opt.in_full_scale)},
                     SignalScale{static_cast<float>(opt.out_full_scale)});
        for (long k = 0; k < n; ++k) {
            const Q31 y = c->apply(k == 0 ? x0 : Q31::from_raw(0));
            saturated = saturated || y.raw() == Q31::kMaxRaw || y.raw() == Q31::kMinRaw;
            // back to physical gain: y * out / (amplitude * in)
            h[static_cast<size_t>(k)] = y.to_double() / (amplitude * io);
        }
        // A few LSB per sample (output rounding, unshaped product floors),
        // times what the later sections make of the earlier ones' rounding.
        lsb = 4.0 * std::ldexp(1.0, -31) * q31_noise_amplification(sections, std::min(n, 200000L));
    }
    if (saturated)
        r.warnings.push_back("the output saturated during the impulse measurement: scale the sections (l1) or "
                             "raise out_full_scale");
    // Rounding noise per output sample, in the units of h (physical gain).
    const double sample_noise = lsb / (amplitude * (opt.format == SampleFormat::kQ31 ? io : 1.0));
    // Tail check: the last tenth of the record should hold no more energy
    // than 1e-12 of the total (the decay the length was chosen for) plus
    // 100 times the rounding noise.
    double total = 0.0, tail = 0.0;
    for (long k = 0; k < n; ++k) {
        const double e = h[static_cast<size_t>(k)] * h[static_cast<size_t>(k)];
        total += e;
        if (k >= n - n / 10) tail += e;
    }
    const double tail_noise = 100.0 * static_cast<double>(n / 10) * sample_noise * sample_noise;
    if (total > 0.0 && tail > 1e-12 * total + tail_noise)
        r.warnings.push_back(cat("the impulse response has not decayed after ", std::to_string(n),
                                 " samples (tail energy ", format::significant(tail / total, 2),
                                 "): the realisation is (nearly) unstable or slower than the design"));

    // 4. Response at log-spaced frequencies up to Nyquist.
    const std::vector<double> f = logspace(opt.f_min_hz, 0.999 * 0.5 * rate, opt.frequencies);
    const std::vector<cplx> hd = freqresp(design, hz_to_rad_s(f));
    // DFT noise of the record, in physical gain units.
    const double noise = std::sqrt(static_cast<double>(n)) * sample_noise;
    for (size_t i = 0; i < f.size(); ++i) {
        ResponsePoint p;
        p.f_hz = f[i];
        p.design = hd[i];
        p.realised = dft_at(h, 2.0 * std::numbers::pi * f[i] / rate);
        const cplx ratio = p.realised / p.design;
        p.error_db = 20.0 * std::log10(std::abs(ratio));
        p.phase_error_deg = std::arg(ratio) * 180.0 / std::numbers::pi;
        // Counted where the noise is below 1/300 of the response (<= 0.03 dB).
        p.counted = std::abs(p.design) >= 300.0 * noise;
        if (p.counted && (std::fabs(p.error_db) > r.max_error_db || !std::isfinite(p.error_db))) {
            r.max_error_db = std::fabs(p.error_db);
            r.worst_f_hz = p.f_hz;
        }
        if (p.counted) r.max_phase_error_deg = std::max(r.max_phase_error_deg, std::fabs(p.phase_error_deg));
        r.response.push_back(p);
    }
    if (!(r.max_error_db <= opt.max_error_db) || !(r.max_phase_error_deg <= opt.max_phase_error_deg))
        r.warnings.push_back(cat("the ", fmt_name, " response deviates from the design by up to ",
                                 format::significant(r.max_error_db, 3), " dB (worst at ",
                                 format::significant(r.worst_f_hz, 4),
                                 " Hz) and ", format::significant(r.max_phase_error_deg, 3),
                                 " deg (limits ", format::significant(opt.max_error_db, 3), " dB, ",
                                 format::significant(opt.max_phase_error_deg, 3), " deg): this realisation is unfit",
                                 opt.format == SampleFormat::kFloat ? "; use --format q31" : ""));
    r.fit = r.warnings.empty();
    return r;
}

nlohmann::json to_json(const RealisationReport& r) {
    nlohmann::json j;
    j["format"] = sample_format_name(r.format);
    j["configured"] = r.configured;
    if (!r.configured) j["configure_error"] = r.configure_error;
    j["fit"] = r.fit;
    j["warnings"] = r.warnings;
    j["section_forms"] = r.section_forms;
    if (!r.configured) return j;
    j["measurement"] = "DFT of the impulse response of the core's BiquadCascade, vs the double-precision design";
    j["impulse_samples"] = r.impulse_samples;
    j["max_error_db"] = r.max_error_db;
    j["max_phase_error_deg"] = r.max_phase_error_deg;
    j["worst_frequency_hz"] = r.worst_f_hz;
    j["max_relative_pole_shift"] = r.max_relative_pole_shift;
    nlohmann::json poles = nlohmann::json::array();
    for (const PoleShift& p : r.poles)
        poles.push_back({{"section", p.section},
                         {"design", {p.design.real(), p.design.imag()}},
                         {"realised", {p.realised.real(), p.realised.imag()}},
                         {"shift", p.shift},
                         {"relative_shift", p.relative_shift}});
    j["poles"] = poles;
    nlohmann::json resp = nlohmann::json::array();
    for (const ResponsePoint& p : r.response)
        resp.push_back({{"f_hz", p.f_hz},
                        {"design_db", magnitude_db(p.design)},
                        {"design_deg", phase_deg(p.design)},
                        {"error_db", p.error_db},
                        {"phase_error_deg", p.phase_error_deg},
                        {"counted", p.counted}});
    j["response"] = resp;
    return j;
}

}  // namespace piezoloop::design
