// The scope's frames (host/ui/scope_view): the roll window ends at the
// newest sample; the triggered window puts the latest crossing that leaves
// room for the rest of the window at trigger_fraction of the width (checked
// against a scan of every sample); the series decode to the decimation's values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>

#include "ui/min_max_columns.hpp"
#include "ui/scope_view.hpp"

namespace piezoloop::ui {
namespace {

constexpr double kRate_Hz = 10000.0;

std::vector<float> decode(const std::string& b64) {
    auto digit = [](char c) -> uint32_t {
        if (c >= 'A' && c <= 'Z') return c - 'A';
        if (c >= 'a' && c <= 'z') return c - 'a' + 26;
        if (c >= '0' && c <= '9') return c - '0' + 52;
        return c == '+' ? 62 : 63;
    };
    std::vector<unsigned char> bytes;
    for (std::size_t i = 0; i + 3 < b64.size(); i += 4) {
        const uint32_t n = digit(b64[i]) << 18 | digit(b64[i + 1]) << 12 |
                           (b64[i + 2] == '=' ? 0 : digit(b64[i + 2]) << 6) | (b64[i + 3] == '=' ? 0 : digit(b64[i + 3]));
        bytes.push_back(static_cast<unsigned char>(n >> 16));
        if (b64[i + 2] != '=') bytes.push_back(static_cast<unsigned char>(n >> 8));
        if (b64[i + 3] != '=') bytes.push_back(static_cast<unsigned char>(n));
    }
    std::vector<float> out(bytes.size() / 4);
    std::memcpy(out.data(), bytes.data(), out.size() * 4);
    return out;
}

void fill_sine(SampleHistory& h, std::size_t n, std::vector<double>& t, std::vector<float>& v) {
    for (std::size_t i = 0; i < n; ++i) {
        const float x = static_cast<float>(std::sin(2 * std::numbers::pi * 47.0 * static_cast<double>(i) / kRate_Hz));
        const float both[2] = {x, -x};
        h.append(i, both, 1000);
        t.push_back(static_cast<double>(i) / kRate_Hz);
        v.push_back(x);
    }
}

SampleHistory two_signals() { return SampleHistory({{"r", "um"}, {"u", "V"}}, kRate_Hz, 1 << 20); }

TEST(UiScopeView, RollShowsTheNewestSpanDecimated) {
    std::vector<double> t;
    std::vector<float> v;
    SampleHistory h = two_signals();
    fill_sine(h, 3000, t, v);
    ScopeSettings s;
    s.span_s = 0.05;
    s.columns = 100;
    ScopeView view;
    const auto f = view.next_frame(h, s, 0);
    ASSERT_TRUE(f);
    EXPECT_DOUBLE_EQ((*f)["t0_s"].get<double>(), 3000 / kRate_Hz - 0.05);
    EXPECT_EQ((*f)["samples"].get<std::size_t>(), 500u);
    const std::vector<float> r = decode((*f)["series"]["r"].get<std::string>());
    const ColumnPoints want = min_max_columns(t, v, (*f)["t0_s"].get<double>(), 0.05, 100);
    ASSERT_EQ(r.size(), 200u);
    for (std::size_t c = 0; c < 100; ++c) {
        EXPECT_EQ(r[2 * c], want.first[c]);
        EXPECT_EQ(r[2 * c + 1], want.second[c]);
    }
    EXPECT_FALSE(view.next_frame(h, s, 0));  // nothing new
}

TEST(UiScopeView, TriggeredPutsTheLatestCrossingAtItsFraction) {
    std::vector<double> t;
    std::vector<float> v;
    SampleHistory h = two_signals();
    fill_sine(h, 4000, t, v);
    for (const bool rising : {true, false}) {
        ScopeSettings s;
        s.triggered = true;
        s.rising = rising;
        s.trigger_level = 0.3;
        s.span_s = 0.03;
        s.trigger_fraction = 0.25;
        ScopeView view;
        const auto f = view.next_frame(h, s, 0);
        ASSERT_TRUE(f);
        // The scan: the latest i with the crossing and room after it.
        const double latest = 4000 / kRate_Hz - (1 - s.trigger_fraction) * s.span_s;
        double want = -1;
        for (std::size_t i = 1; i < v.size(); ++i) {
            const bool crossed = rising ? v[i - 1] < 0.3f && v[i] >= 0.3f : v[i - 1] > 0.3f && v[i] <= 0.3f;
            if (crossed && t[i] <= latest) want = t[i];
        }
        ASSERT_GT(want, 0);
        EXPECT_DOUBLE_EQ((*f)["trigger_t_s"].get<double>(), want);
        EXPECT_DOUBLE_EQ((*f)["t0_s"].get<double>(), want - 0.25 * 0.03);
    }
}

// Other channels (the page picks them): the history starts again with the
// new signals, its generation counts the change, the frames and the CSV
// carry the new ones only, and a trigger on a signal no longer recorded
// gives no frame (rather than reading a column that is gone).
TEST(UiScopeView, OtherChannelsStartTheHistoryAgain) {
    std::vector<double> t;
    std::vector<float> v;
    SampleHistory h = two_signals();
    fill_sine(h, 1000, t, v);
    EXPECT_EQ(h.generation(), 0u);
    h.reset({{"y.u", "V"}, {"z.y", "um"}, {"e", "um"}});
    EXPECT_EQ(h.generation(), 1u);
    EXPECT_EQ(h.size(), 0u);
    ASSERT_EQ(h.signals().size(), 3u);
    EXPECT_FALSE(h.find("r"));
    EXPECT_EQ(h.find("z.y"), 1u);
    for (uint64_t i = 0; i < 100; ++i) {
        const float three[3] = {static_cast<float>(i), -1.0f, 0.5f};
        h.append(i, three, 1000);
    }
    ScopeSettings roll;
    roll.span_s = 0.005;
    roll.columns = 10;
    ScopeView view;
    const auto f = view.next_frame(h, roll, 0);
    ASSERT_TRUE(f);
    EXPECT_EQ((*f)["series"].size(), 3u);
    EXPECT_TRUE((*f)["series"].contains("y.u"));
    EXPECT_EQ((*f)["units"]["y.u"], "V");
    EXPECT_EQ(decode((*f)["series"]["z.y"].get<std::string>()).front(), -1.0f);
    EXPECT_EQ(window_csv(h, 0.0, 1.0).substr(0, 23), "t_s,y.u_V,z.y_um,e_um\n0");
    ScopeSettings gone = roll;
    gone.triggered = true;
    gone.trigger_signal = "r";
    ScopeView triggered;
    EXPECT_FALSE(triggered.next_frame(h, gone, 0));
}

TEST(UiScopeView, SettingsOutOfRangeAreRefusedNamingTheKey) {
    std::vector<double> t;
    std::vector<float> v;
    SampleHistory h = two_signals();
    fill_sine(h, 10, t, v);
    const ScopeSettings s;
    EXPECT_THROW(merge_scope_settings({{"span_s", 0.0}}, s, h), std::invalid_argument);
    EXPECT_THROW(merge_scope_settings({{"trigger_signal", "q"}}, s, h), std::invalid_argument);
    EXPECT_THROW(merge_scope_settings({{"mode", "auto"}}, s, h), std::invalid_argument);
    EXPECT_THROW(merge_scope_settings({{"colour", 1}}, s, h), std::invalid_argument);
    try {
        merge_scope_settings({{"columns", 3}}, s, h);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("scope.columns"), std::string::npos) << e.what();
    }
    EXPECT_EQ(merge_scope_settings({{"edge", "falling"}, {"span_s", 0.2}}, s, h).span_s, 0.2);
}

// A cursor takes the sample nearest its time, none beyond a tick from every
// sample; a value not recorded (NaN) is null.
TEST(UiScopeCursor, TheNearestSampleAndItsValues) {
    SampleHistory h({{"r", "um"}, {"u", "V"}}, kRate_Hz, 1000);
    for (uint64_t k = 0; k < 100; ++k) {
        const float r = 0.25f * static_cast<float>(k), u = k == 50 ? NAN : -static_cast<float>(k);
        const float values[] = {r, u};
        h.append(k < 60 ? k : k + 20, values, 0);  // a gap of 20 ticks after tick 59
    }
    const double tick = 1.0 / kRate_Hz;
    const auto at = [&](double t) { return cursor_sample(h, t); };
    nlohmann::json c = at(10.3 * tick);
    EXPECT_DOUBLE_EQ(c["t_s"].get<double>(), 10 * tick);
    EXPECT_EQ(c["values"]["r"], 2.5);
    EXPECT_EQ(c["values"]["u"], -10.0);
    EXPECT_DOUBLE_EQ(at(10.7 * tick)["t_s"].get<double>(), 11 * tick);
    EXPECT_DOUBLE_EQ(at(10.49 * tick)["t_s"].get<double>(), 10 * tick);
    EXPECT_DOUBLE_EQ(at(10.51 * tick)["t_s"].get<double>(), 11 * tick);
    EXPECT_TRUE(at(50 * tick)["values"]["u"].is_null());
    EXPECT_EQ(at(50 * tick)["values"]["r"], 12.5);
    EXPECT_DOUBLE_EQ(at(59.9 * tick)["t_s"].get<double>(), 59 * tick);  // the last before the gap
    EXPECT_TRUE(at(60.4 * tick)["t_s"].is_null());  // 1.4 ticks from it: none
    EXPECT_TRUE(at(70 * tick)["t_s"].is_null());   // inside the gap, 10 ticks from any sample
    EXPECT_TRUE(at(-5 * tick)["t_s"].is_null());   // before the record
    EXPECT_DOUBLE_EQ(at(79.6 * tick)["t_s"].get<double>(), 80 * tick);  // the first after the gap
    EXPECT_EQ(at(79.6 * tick)["values"]["r"], 15.0);                      // k = 60
}

}  // namespace
}  // namespace piezoloop::ui
