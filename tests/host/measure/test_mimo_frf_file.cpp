// The MIMO frequency response file (host/measure/mimo_frf_file): what the
// writer writes reads back bit for bit (17 significant digits), an unknown
// standard deviation as nan, and a malformed file is refused naming the
// line and the field.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "measure/mimo_frf_file.hpp"
#include "mimo_reference.hpp"
#include "test_support.hpp"

using namespace piezoloop;

namespace {

std::string temp_path(const std::string& name) { return ::testing::TempDir() + "mimo_frf_" + name; }

measure::MimoFrfEstimate measured(int index, int periods) {
    const test::MimoCase c = test::mimo_case(index);
    const measure::MimoFrfPlan p = measure::plan_mimo_frf(test::mimo_request(c, periods, 4));
    std::vector<std::vector<std::vector<double>>> u;
    for (int b = 0; b < p.inputs; ++b) u.push_back(measure::mimo_block(p, b));
    return measure::estimate_mimo_frf(p, u, test::mimo_simulate(c, u));
}

std::string write_text(const std::string& name, const std::string& text) {
    const std::string path = temp_path(name);
    std::ofstream(path) << text;
    return path;
}

std::string read_text(const std::string& path) {
    std::ifstream f(path);
    return std::string(std::istreambuf_iterator<char>(f), {});
}

}  // namespace

TEST(MimoFrfFile, RoundTrip) {
    for (int index : {0, 1}) {
        const measure::MimoFrfEstimate e = measured(index, 2);
        const std::string path = temp_path("round_trip.csv");
        measure::write_mimo_frf(path, e);
        const measure::MimoFrfEstimate r = measure::load_mimo_frf_file(path);
        EXPECT_EQ(r.inputs, e.inputs);
        EXPECT_EQ(r.outputs, e.outputs);
        EXPECT_EQ(r.periods, 2);
        EXPECT_EQ(r.rate_Hz, e.rate_Hz);
        ASSERT_EQ(r.frequency_Hz, e.frequency_Hz);
        for (std::size_t k = 0; k < e.frequency_Hz.size(); ++k) {
            EXPECT_EQ(r.response[k], e.response[k]);
            EXPECT_EQ(r.std_dev[k], e.std_dev[k]);
        }
        measure::write_mimo_frf_summary(path + ".json", e);
        const nlohmann::json s = nlohmann::json::parse(read_text(path + ".json"));
        EXPECT_EQ(s, measure::mimo_frf_summary(e));
        EXPECT_EQ(s["inputs"], e.inputs);
        EXPECT_EQ(s["lines"], 200);
        EXPECT_EQ(s["elements"].size(), static_cast<std::size_t>(e.inputs * e.outputs));
        EXPECT_NEAR(s["max_input_condition"].get<double>(), 1.0, 1e-9);
        // Noise-free: SNR > 100 dB everywhere (the spread is rounding).
        for (const auto& el : s["elements"])
            if (!el["min_snr_db"].is_null()) {
                EXPECT_GT(el["min_snr_db"].get<double>(), 100.0) << el;
            }
    }
}

TEST(MimoFrfFile, UnknownStandardDeviation) {
    const measure::MimoFrfEstimate e = measured(0, 1);
    const std::string path = temp_path("one_period.csv");
    measure::write_mimo_frf(path, e);
    const std::string text = read_text(path);
    EXPECT_EQ(text.rfind("# piezoloop mimo-frf 1\n# inputs=2 outputs=2 rate_Hz=10000 periods=1\n"
                         "f_Hz,G11_re,G11_im,G11_std,G12_re,G12_im,G12_std,G21_re,G21_im,G21_std,G22_re,G22_im,G22_std\n",
                         0),
              0u);
    const measure::MimoFrfEstimate r = measure::load_mimo_frf_file(path);
    EXPECT_TRUE(std::isnan(r.std_dev[3](1, 0)));
    EXPECT_TRUE(measure::mimo_frf_summary(r)["elements"][0]["min_snr_db"].is_null());
}

TEST(MimoFrfFile, MalformedIsRefusedNamingLineAndField) {
    const std::string head = "# piezoloop mimo-frf 1\n# inputs=2 outputs=2 rate_Hz=1000 periods=4\n" +
                             measure::mimo_frf_columns(2, 2) + "\n";
    const std::string row = "10,1,0,0.1,0.02,0,nan,0.03,0,0,0.9,0.1,0.01\n";
    auto why = [&](const std::string& name, const std::string& text) {
        return test::error_of([&] { measure::load_mimo_frf_file(write_text(name, text)); });
    };
    EXPECT_EQ(why("good", head + row), "");
    EXPECT_NE(test::error_of([] { measure::load_mimo_frf_file("/nonexistent/g.csv"); }).find("cannot read"),
              std::string::npos);
    EXPECT_NE(why("magic", "f_Hz,G11_re\n").find("line 1: header: must be \"# piezoloop mimo-frf 1\""), std::string::npos);
    EXPECT_NE(why("no_rate", "# piezoloop mimo-frf 1\n# inputs=2 outputs=2 periods=4\n").find("line 2: rate_Hz: missing"),
              std::string::npos);
    EXPECT_NE(why("bad_n", "# piezoloop mimo-frf 1\n# inputs=2.5 outputs=2 rate_Hz=1 periods=4\n")
                  .find("line 2: inputs: must be an integer in [1, 16]"),
              std::string::npos);
    // n in the header and the columns disagree.
    const std::string three = "# piezoloop mimo-frf 1\n# inputs=3 outputs=3 rate_Hz=1000 periods=4\n" +
                              measure::mimo_frf_columns(2, 2) + "\n" + row;
    EXPECT_NE(why("mismatch", three).find("line 3: column 8: is \"G21_re\", inputs=3 outputs=3 need \"G13_re\""),
              std::string::npos)
        << why("mismatch", three);
    EXPECT_NE(why("short_row", head + "10,1,0,0.1\n").find("line 4: row: must have 13 values (got 4)"), std::string::npos);
    EXPECT_NE(why("bad_value", head + "10,1,0,0.1,0.02,x,nan,0.03,0,0,0.9,0.1,0.01\n").find("line 4: G12_im: must be a finite number"),
              std::string::npos);
    EXPECT_NE(why("nan_value", head + "10,nan,0,0.1,0.02,0,nan,0.03,0,0,0.9,0.1,0.01\n").find("line 4: G11_re"),
              std::string::npos);
    EXPECT_NE(why("neg_std", head + "10,1,0,-0.1,0.02,0,nan,0.03,0,0,0.9,0.1,0.01\n").find("line 4: G11_std: must be"),
              std::string::npos);
    EXPECT_NE(why("order", head + row + row).find("line 5: f_Hz: must increase"), std::string::npos);
    EXPECT_NE(why("nyquist", head + "600" + row.substr(2)).find("line 4: f_Hz: must be in (0, 500] Hz"), std::string::npos);
    EXPECT_NE(why("empty", head).find("line 4: f_Hz: no lines"), std::string::npos);
}
