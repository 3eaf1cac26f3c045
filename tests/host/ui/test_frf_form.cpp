// The console's frequency-response form (host/ui/frf_job): its fields, the
// plan's refusals at the form's field names, and the unwrapped phase.
#include <gtest/gtest.h>

#include <cmath>

#include "ui/frf_job.hpp"

namespace piezoloop::ui {
namespace {

using nlohmann::json;

TEST(UiFrfForm, TheFieldsBecomeTheRequest) {
    const FrfForm f = parse_frf_form({{"from_Hz", 50}, {"to_Hz", 2000}, {"amplitude_V", 0.09}, {"bias_V", 3},
                                      {"periods", 4}, {"transient_periods", 1}, {"signal", "sweep"}, {"mode", "closed"},
                                      {"restart_stage", true}, {"fit_order", "4/2"}});
    EXPECT_EQ(f.request.from_Hz, 50.0);
    EXPECT_EQ(f.request.to_Hz, 2000.0);
    EXPECT_EQ(f.request.amplitude_V, 0.09);
    EXPECT_EQ(f.request.bias_V, 3.0);
    EXPECT_EQ(f.request.periods, 4);
    EXPECT_EQ(f.request.transient_periods, 1);
    EXPECT_EQ(f.request.signal, "sweep");
    EXPECT_TRUE(f.request.closed);
    EXPECT_TRUE(f.restart_stage);
    EXPECT_EQ(f.fit_poles, 4);
    EXPECT_EQ(f.fit_zeros, 2);
    EXPECT_EQ(parse_frf_form({{"from_Hz", 1}, {"to_Hz", 2}, {"amplitude_V", 0.1}, {"fit_order", ""}}).fit_poles, 0);
    const FrfForm n = parse_frf_form({{"from_Hz", 1}, {"to_Hz", 2}, {"amplitude_V", 0.1}, {"fit_order", "4"}});
    EXPECT_EQ(n.fit_poles, 4);  // N alone: N - 1 zeros, as `identify tf --order`
    EXPECT_EQ(n.fit_zeros, 3);
}

std::string refused_field(const json& j) {
    try {
        parse_frf_form(j);
    } catch (const FieldRefusal& e) {
        return e.field;
    }
    return "(accepted)";
}

TEST(UiFrfForm, BadFieldsAreRefusedAtTheirField) {
    const json ok = {{"from_Hz", 50}, {"to_Hz", 2000}, {"amplitude_V", 0.09}};
    auto with = [&](const char* k, const json& v) {
        json j = ok;
        j[k] = v;
        return j;
    };
    EXPECT_EQ(refused_field(with("to_Hz", nullptr)), "to_Hz");  // NaN from the page arrives as null
    EXPECT_EQ(refused_field(with("periods", 2.5)), "periods");
    EXPECT_EQ(refused_field(with("signal", "chirp")), "signal");
    EXPECT_EQ(refused_field(with("mode", "half")), "mode");
    EXPECT_EQ(refused_field(with("fit_order", "x4")), "fit_order");
    EXPECT_EQ(refused_field(with("fit_order", "4/")), "fit_order");
    EXPECT_EQ(refused_field(with("fit_order", "2/3")), "fit_order");  // more zeros than poles
    EXPECT_EQ(refused_field(with("fit_order", "4/2x")), "fit_order");
    EXPECT_EQ(refused_field(with("colour", "red")), "");
    EXPECT_EQ(refused_field({{"from_Hz", 50}, {"to_Hz", 2000}}), "amplitude_V");
}

// Whole-number fields beyond an int's reach are refused at their field,
// with the text every form gives.
TEST(UiFrfForm, AWholeNumberTooLargeIsRefusedAtItsField) {
    const json j = {{"from_Hz", 50}, {"to_Hz", 2000}, {"amplitude_V", 0.09}, {"transient_periods", 3e9}};
    try {
        parse_frf_form(j);
        FAIL() << "3e9 transient periods accepted";
    } catch (const FieldRefusal& e) {
        EXPECT_EQ(e.field, "transient_periods");
        EXPECT_STREQ(e.what(), "transient_periods: must be a whole number");
    }
}

TEST(UiFrfForm, ThePlansRefusalNamesTheFormsField) {
    const FieldRefusal a = form_refusal("--to-hz: must be below the Nyquist frequency, rate / 2 = 5000 Hz");
    EXPECT_EQ(a.field, "to_Hz");
    EXPECT_STREQ(a.what(), "to_Hz: must be below the Nyquist frequency, rate / 2 = 5000 Hz");
    const FieldRefusal b = form_refusal("--periods: (--transient-periods + --periods) x 200 ticks: lower --periods");
    EXPECT_EQ(b.field, "periods");
    EXPECT_STREQ(b.what(), "periods: (transient_periods + periods) x 200 ticks: lower periods");
    EXPECT_EQ(form_refusal("--transient-periods: must be in [0, 100]").field, "transient_periods");
    EXPECT_EQ(form_refusal("--mode closed: the board has no feedback controller").field, "mode");
    EXPECT_EQ(form_refusal("the board is running a wave: stop it first").field, "");
}

// A pure delay of tau: phase -360 f tau degrees, past many turns. The
// reference is analytic; 1e-9 deg is rounding in atan2 and the sum of turns.
TEST(UiFrfForm, ThePhaseIsUnwrappedAlongTheLines) {
    const double tau = 1.3e-3;
    std::vector<double> f;
    std::vector<std::complex<double>> g;
    for (int i = 1; i <= 400; ++i) {
        f.push_back(10.0 * i);
        g.push_back(std::polar(2.0, -2.0 * M_PI * f.back() * tau));
    }
    const std::vector<double> p = unwrapped_phase_deg(g);
    ASSERT_EQ(p.size(), g.size());
    for (std::size_t i = 0; i < p.size(); ++i) EXPECT_NEAR(p[i], -360.0 * f[i] * tau, 1e-9) << f[i] << " Hz";
    EXPECT_LT(p.back(), -1800.0);
}

}  // namespace
}  // namespace piezoloop::ui
