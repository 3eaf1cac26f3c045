// The spectrum view's Welch PSD (host/ui/psd) against scipy.signal.welch
// (tools/ref/ui_welch.py -> tests/golden/ui_welch.json): records of float32
// samples (two tones, an offset, noise), segments shorter than the record
// and one longer. Tolerance: 1e-9 of the spectrum's peak, absolute: both
// compute in double from the same float inputs, and differ only by the FFT's
// rounding (about 1e-15 relative to the largest bin).
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include <nlohmann/json.hpp>

#include "ui/psd.hpp"

namespace piezoloop::ui {
namespace {

TEST(UiPsd, EqualsScipyWelch) {
    std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/ui_welch.json");
    ASSERT_TRUE(f) << "tests/golden/ui_welch.json";
    const nlohmann::json cases = nlohmann::json::parse(f);
    ASSERT_EQ(cases.size(), 3u);
    for (const auto& c : cases) {
        const std::vector<double> xd = c["x"].get<std::vector<double>>();
        std::vector<float> x(xd.begin(), xd.end());  // float32 values, exact
        const Psd p = welch_psd(x, c["rate_Hz"].get<double>(), c["segment"].get<std::size_t>());
        const std::vector<double> fr = c["frequency_Hz"].get<std::vector<double>>();
        const std::vector<double> want = c["psd"].get<std::vector<double>>();
        ASSERT_EQ(p.density.size(), want.size());
        const double peak = *std::max_element(want.begin(), want.end());
        for (std::size_t b = 0; b < want.size(); ++b) {
            EXPECT_NEAR(p.frequency_Hz[b], fr[b], 1e-9 * fr.back()) << b;
            EXPECT_NEAR(p.density[b], want[b], 1e-9 * peak) << "bin " << b << " of segment " << c["segment"];
        }
    }
}

TEST(UiPsd, ATonesPowerIsItsMeanSquare) {
    // Parseval: the density summed over the bins times their width is the
    // variance; a 1 V amplitude sine has 0.5 V^2 (the Hann window's leakage
    // stays inside the sum).
    std::vector<float> x(8192);
    for (std::size_t i = 0; i < x.size(); ++i) x[i] = static_cast<float>(std::sin(2 * 3.141592653589793 * 1000.0 * i / 1e4));
    const Psd p = welch_psd(x, 1e4, 1024);
    double power = 0.0;
    for (double d : p.density) power += d * (1e4 / 1024);
    EXPECT_NEAR(power, 0.5, 1e-3);  // float32 input: about 1e-7 relative, and the DC bin's share of the window
}

TEST(UiPsd, RefusesWhatItCannotEstimate) {
    const std::vector<float> few(10, 1.0f), some(100, 1.0f);
    EXPECT_THROW(welch_psd(few, 1e4, 64), std::invalid_argument);
    EXPECT_THROW(welch_psd(some, 1e4, 8), std::invalid_argument);
    EXPECT_THROW(welch_psd(some, 0.0, 64), std::invalid_argument);
}

}  // namespace
}  // namespace piezoloop::ui
