// Every linear controller in configs/ through the realisation check, in
// float (the type of the qemu-m7 and STM32H743 boards) and Q31, at 10, 20,
// 50 and 100 kHz: the core's cascade object must reproduce the
// double-precision design within 0.1 dB and 1 degree from 0.01 Hz to
// 0.999 Nyquist (the check's own criteria, host/lti/realisation.hpp).
//   ahmad2020_K, janaideh2016_C: the feedback of the Ahmad2020 and
//     Janaideh2016 scenarios, as host/sim/build_case.cpp makes it: times the
//     scenario's error_per_um, Tustin, zpk2sos; for Q31 L1-scaled from the
//     position full scale (µm) to the command full scale (V).
//   shan2012_Q: the repetitive controller's Q filter, discrete at 100 kHz.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "lti/c2d.hpp"
#include "lti/model_json.hpp"
#include "lti/realisation.hpp"
#include "lti/sos.hpp"

using namespace piezoloop;
using namespace piezoloop::design;

namespace {

std::string model_path(const std::string& name) {
    return std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../configs/models/" + name + ".json";
}

RealisationReport check(const Zpk& discrete, SampleFormat format, double in_fs, double out_fs) {
    std::vector<SosSection> sos = zpk2sos(discrete);
    if (format == SampleFormat::kQ31) {
        SosScaling sc;
        sc.norm = SosNorm::kL1;
        sc.in_full_scale = in_fs;
        sc.out_full_scale = out_fs;
        sos = scale_sos(sos, sc);
    }
    RealisationOptions o;
    o.format = format;
    o.in_full_scale = in_fs;
    o.out_full_scale = out_fs;
    return check_realisation(discrete, sos, o);
}

void expect_fit(const RealisationReport& r, const std::string& what) {
    ASSERT_TRUE(r.configured) << what << ": " << r.configure_error;
    EXPECT_TRUE(r.fit) << what << ": " << (r.warnings.empty() ? "" : r.warnings[0]);
    EXPECT_LE(r.max_error_db, 0.1) << what;
    EXPECT_LE(r.max_phase_error_deg, 1.0) << what;
    ASSERT_FALSE(r.response.empty());
    EXPECT_NEAR(r.response.front().f_hz, 0.01, 1e-12) << what;
    EXPECT_FALSE(r.section_forms.empty()) << what;
    std::string forms;
    for (const std::string& f : r.section_forms)
        forms += f.find("delta") != std::string::npos ? " delta" : f.find("transposed") != std::string::npos ? " df2t" : " df1";
    std::printf("%-28s %-5s %.2g dB %.2g deg (worst at %.3g Hz), poles moved %.2g of their distance; forms%s\n",
                what.c_str(), sample_format_name(r.format), r.max_error_db, r.max_phase_error_deg, r.worst_f_hz,
                r.max_relative_pole_shift, forms.c_str());
}

}  // namespace

TEST(DesignRealisationConfigs, SourceControllersAreFitInFloatAndQ31AtEveryRate) {
    // configs/ahmad2020.json and janaideh2016.json: error_per_um, position
    // and voltage full scales.
    struct Controller {
        const char* model;
        double error_per_um, in_fs, out_fs;
    };
    const Controller controllers[] = {{"ahmad2020_K", 0.333333, 40.0, 16.0}, {"janaideh2016_C", 0.22727, 64.0, 16.0}};
    for (const Controller& c : controllers) {
        Zpk k = load_model_file(model_path(c.model));
        k.gain *= c.error_per_um;
        for (const double rate : {1e4, 2e4, 5e4, 1e5}) {
            const Zpk d = tustin(k, 1.0 / rate);
            const std::string what = std::string(c.model) + " at " + std::to_string(static_cast<int>(rate)) + " Hz";
            expect_fit(check(d, SampleFormat::kFloat, c.in_fs, c.out_fs), what);
            expect_fit(check(d, SampleFormat::kQ31, c.in_fs, c.out_fs), what);
        }
    }
    // Shan2012 Q(z) is given in discrete time at its 100 kHz.
    const Zpk q = load_model_file(model_path("shan2012_Q"));
    expect_fit(check(q, SampleFormat::kFloat, 1.0, 1.0), "shan2012_Q at 100000 Hz");
    expect_fit(check(q, SampleFormat::kQ31, 1.0, 1.0), "shan2012_Q at 100000 Hz");
}
