// The closed loop of a stage of coupled axes (sim/multi_axis_loop.hpp,
// sim/multi_axis_sim_case.hpp): one axis through it is the single-axis
// simulator bit for bit (log hash and metrics); uncoupled axes with identity
// matrices are independent single-axis runs bit for bit; float and Q31
// agree; the cross motion is the peak-to-peak of the logged positions; the
// shipped XYZ flexure's cases reach their figures (and miss them without
// feedback or decoupling); bad cases are refused naming the field.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <string>

#include "coupled_stage_fixture.hpp"
#include "sim/multi_axis_sim_case.hpp"
#include "test_support.hpp"

using namespace piezoloop;
using namespace piezoloop::sim;

namespace {

Scenario xyz() { return load_scenario(test::configs_dir() + "stages/xyz_flexure.json"); }

nlohmann::json xyz_json() {
    std::ifstream f(test::configs_dir() + "stages/xyz_flexure.json");
    return nlohmann::json::parse(f);
}

std::string parse_error(const nlohmann::json& j) {
    try {
        (void)parse_scenario(j, test::configs_dir() + "stages");
    } catch (const ScenarioError& e) {
        return e.what();
    }
    return "";
}

// A 10 Hz triangle over 10-90 um on x, y and z held at mid-range.
MultiAxisSimRequest triangle_on_x(const std::string& case_name) {
    MultiAxisSimRequest r;
    r.sim.case_name = case_name;
    r.sim.frequency_Hz = 10.0;
    r.sim.amplitude_um = 80.0;
    r.sim.midpoint_um = 50.0;
    r.axis = "x";
    r.holds = {"y=50", "z=7.5"};
    r.check_realisation = false;
    return r;
}

struct Figures {
    double e_max_x_um, cross_y_pct, cross_z_pct;
};

Figures run_figures(const Scenario& s, const MultiAxisSimRequest& r) {
    const MultiAxisSimPlan p = plan_multi_axis_sim(s, r);
    const MultiAxisRunResult res = run_multi_axis(p.model, p.options);
    return {res.axes[0].tracking.e_max_um, cross_motion_pct(res, 0, 1), cross_motion_pct(res, 0, 2)};
}

}  // namespace

// One axis through the multi-axis loop: the single-axis simulator's log hash
// and metrics exactly (the same arithmetic), float and Q31, with feedback,
// RC and an inverse.
TEST(MultiAxisLoop, OneAxisIsTheSingleAxisSimulator) {
    const Scenario s = load_scenario(test::configs_dir() + "shan2012.json");
    for (const char* sample : {"float", "q31"}) {
        SimCaseRequest req;
        req.case_name = "pi_rc_inv";
        req.frequency_Hz = 50.0;
        req.amplitude_um = 10.0;
        req.sample = sample;
        const SimCasePlan plan = plan_sim_case(s, req);
        const RunResult single = run_loop(plan.built.model, plan.options);

        MultiAxisModel m = build_multi_axis_case(s, plan.case_spec, BuildOptions{50.0, 10, false, {}});
        ASSERT_EQ(m.axes.size(), 1u);
        MultiAxisRunOptions o;
        o.wave = plan.options.wave;
        o.hold_um = {0.0f};
        o.ticks = plan.options.ticks;
        o.window_start = plan.options.window_start;
        const MultiAxisRunResult multi = run_multi_axis(m, o);
        EXPECT_EQ(multi.log_hash, single.log_hash) << sample;
        EXPECT_EQ(multi.axes[0].tracking.e_max_um, single.tracking.e_max_um) << sample;
        EXPECT_EQ(multi.axes[0].tracking.e_rms_um, single.tracking.e_rms_um) << sample;
        EXPECT_EQ(multi.axes[0].clamped_samples, single.clamped_samples) << sample;
    }
}

// Identity matrices and no coupling path: every axis computes what it
// computes alone, bit for bit (r, y, u and the position of every tick).
TEST(MultiAxisLoop, UncoupledAxesAreIndependentSingleAxisRuns) {
    Scenario s = xyz();
    s.coupling.clear();
    const CaseSpec& c = s.find_case("pi_notch");
    const MultiAxisModel m = build_multi_axis_case(s, c, BuildOptions{10.0, 10, false, {}});
    MultiAxisRunOptions o;
    o.driven = 0;
    o.wave.waveform = Waveform::kTriangle;
    o.wave.frequency_Hz = 10.0f;
    o.wave.amplitude_um = 40.0f;
    o.wave.offset_um = 45.0f;
    o.wave.sample_rate_Hz = 20000.0f;
    o.hold_um = {0.0f, 40.0f, 5.0f};
    o.ticks = 3000;
    o.window_start = 1000;
    o.log_every = 1;
    const MultiAxisRunResult multi = run_multi_axis(m, o);
    for (size_t i = 0; i < 3; ++i) {
        RunOptions ro;
        ro.wave = i == 0 ? o.wave : hold_wave(o.wave, o.hold_um[i]);
        ro.ticks = o.ticks;
        ro.window_start = o.window_start;
        ro.log_every = 1;
        const RunResult alone = run_loop(m.axes[i].model, ro);
        ASSERT_EQ(alone.log.tick.size(), multi.log.tick.size());
        for (size_t k = 0; k < alone.log.tick.size(); ++k) {
            ASSERT_EQ(alone.log.r_um[k], multi.log.r_um[i][k]) << "axis " << i << " tick " << k;
            ASSERT_EQ(alone.log.y_um[k], multi.log.y_um[i][k]) << "axis " << i << " tick " << k;
            ASSERT_EQ(alone.log.u_V[k], multi.log.u_V[i][k]) << "axis " << i << " tick " << k;
            ASSERT_EQ(alone.log.x_um[k], multi.log.p_um[i][k]) << "axis " << i << " tick " << k;
        }
        EXPECT_EQ(alone.tracking.e_max_um, multi.axes[i].tracking.e_max_um);
    }
}

// The cross motion is the peak-to-peak of the held axis's true position
// over the window, as % of the driven axis's reference range, recomputed
// here from the logged arrays.
TEST(MultiAxisLoop, CrossMotionIsThePeakToPeakOfTheLoggedPosition) {
    const Scenario s = xyz();
    MultiAxisSimRequest r = triangle_on_x("pi_notch");
    r.sim.log = true;
    r.sim.log_every = 1;
    const MultiAxisSimPlan p = plan_multi_axis_sim(s, r);
    const MultiAxisRunResult res = run_multi_axis(p.model, p.options);
    const MultiAxisLog& l = res.log;
    double r_min = 1e9, r_max = -1e9;
    for (size_t k = 0; k < l.tick.size(); ++k)
        if (l.tick[k] >= p.options.window_start) {
            r_min = std::min(r_min, static_cast<double>(l.r_um[0][k]));
            r_max = std::max(r_max, static_cast<double>(l.r_um[0][k]));
        }
    for (size_t j = 1; j < 3; ++j) {
        double lo = 1e9, hi = -1e9;
        for (size_t k = 0; k < l.tick.size(); ++k)
            if (l.tick[k] >= p.options.window_start) {
                lo = std::min(lo, static_cast<double>(l.p_um[j][k]));
                hi = std::max(hi, static_cast<double>(l.p_um[j][k]));
            }
        EXPECT_EQ(cross_motion_pct(res, 0, static_cast<int>(j)), 100.0 * (hi - lo) / (r_max - r_min)) << j;
    }
    EXPECT_GT(r_max - r_min, 75.0);  // 80 um through X's notch pre-filter
}

// Float and Q31 controllers on the same coupled stage: the same loop to
// within the Q31 realisation of the controllers (sections rescaled to the
// 128 um / 16 V full scales, their coefficients and states rounded to Q31).
// Measured: X's e_max 0.5810 / 0.5829 um, Y 0.0757 / 0.0765 %, Z 0.0318 /
// 0.0321 %; the bounds (0.01 um, 0.005 points) are five times that.
TEST(MultiAxisLoop, FloatAndQ31Agree) {
    const Scenario s = xyz();
    MultiAxisSimRequest r = triangle_on_x("pi_notch_decoupled");
    const Figures f = run_figures(s, r);
    r.sim.sample = "q31";
    const Figures q = run_figures(s, r);
    EXPECT_NEAR(f.e_max_x_um, q.e_max_x_um, 0.01);
    EXPECT_NEAR(f.cross_y_pct, q.cross_y_pct, 0.005);
    EXPECT_NEAR(f.cross_z_pct, q.cross_z_pct, 0.005);
}

// The shipped XYZ flexure, 10 Hz triangle over 10-90 um on X, Y and Z held
// at mid-range: feedback with the static decoupling keeps Y and Z within
// 0.1 % of X's range (0.076 %, 0.032 %); feedback alone (Y 0.24 %) or open
// loop (Y 2.8 %, Z 0.95 %) does not.
TEST(MultiAxisLoop, XyzFlexureCrossMotion) {
    const Scenario s = xyz();
    const Figures open = run_figures(s, triangle_on_x("open_loop"));
    const Figures fb = run_figures(s, triangle_on_x("pi_notch"));
    const Figures dec = run_figures(s, triangle_on_x("pi_notch_decoupled"));
    EXPECT_LE(dec.cross_y_pct, 0.1);
    EXPECT_LE(dec.cross_z_pct, 0.1);
    EXPECT_GT(fb.cross_y_pct, 0.1);  // feedback alone
    EXPECT_GT(open.cross_y_pct, 1.0);
    EXPECT_GT(open.cross_z_pct, dec.cross_z_pct);
    EXPECT_LT(dec.e_max_x_um, 1.0);  // 0.58 um
    EXPECT_LT(fb.e_max_x_um, 1.0);
    EXPECT_GT(open.e_max_x_um, 5.0);  // 6.2 um: the hysteresis
}

TEST(MultiAxisLoop, RefusesBadCases) {
    const nlohmann::json base = xyz_json();
    auto with = [&](auto edit) {
        nlohmann::json j = base;
        edit(j["cases"][1]["controller"]);
        return parse_error(j);
    };
    auto starts = [](const std::string& text, const std::string& head) {
        EXPECT_EQ(text.rfind(head, 0), 0u) << text;
    };
    starts(with([](nlohmann::json& c) { c["axes"]["w"] = c["axes"]["x"]; }),
           "cases[1].controller.axes.w: no axis of that name (axes: x, y, z)");
    starts(with([](nlohmann::json& c) { c["axes"].erase("z"); }), "cases[1].controller.axes: axis z has no controller");
    starts(with([](nlohmann::json& c) { c["axes"]["y"]["feedback"]["method"] = "euler"; }),
           "cases[1].controller.axes.y.feedback.method:");
    starts(with([](nlohmann::json& c) { c["output_matrix"] = {{1, 0}, {0, 1}}; }),
           "cases[1].controller.output_matrix: must be 3 rows");
    const std::string singular = with([](nlohmann::json& c) { c["output_matrix"] = {{1, 1, 0}, {1, 1, 0}, {0, 0, 1}}; });
    starts(singular, "cases[1].controller.output_matrix");
    EXPECT_NE(singular.find("singular"), std::string::npos) << singular;
    {
        nlohmann::json j = base;
        j["cases"][1]["plant"] = {{"hysteresis", {{"kind", "none"}, {"gain_um_per_V", 0.7}}}};
        EXPECT_EQ(parse_error(j).rfind("cases[1].plant: a stage of coupled axes takes", 0), 0u) << parse_error(j);
    }
    {
        // One axis runs as a single-axis plant: no matrices.
        nlohmann::json j = base;
        j["plant"]["axes"] = nlohmann::json::array({j["plant"]["axes"][0]});
        j["plant"].erase("coupling");
        j["cases"] = nlohmann::json::array({j["cases"][0]});
        j["cases"][0]["controller"]["output_matrix"] = {{1}};
        EXPECT_EQ(parse_error(j).rfind("cases[0].controller.output_matrix: a stage of one axis has no matrices", 0), 0u)
            << parse_error(j);
    }
    starts(with([](nlohmann::json& c) { c["input_offset_um"] = {1, 2}; }),
           "cases[1].controller.input_offset_um: must hold 3 numbers");
    // A per-axis PID's gains are checked against that axis's path.
    const Scenario s = [&] {
        nlohmann::json j = base;
        j["cases"][1]["controller"]["axes"]["y"]["feedback"] = {
            {"kind", "pid"}, {"kp", 0.1}, {"ki_per_s", -5}, {"u_min_V", -1}, {"u_max_V", 1}};
        return parse_scenario(j, test::configs_dir() + "stages");
    }();
    const std::string pid = test::error_of([&] { (void)build_multi_axis_case(s, s.cases[1], BuildOptions{10.0, 10, false, {}}); });
    EXPECT_EQ(pid.rfind("cases[1].controller.axes.y.feedback", 0), 0u) << pid;

    // The run's options.
    const Scenario x = xyz();
    MultiAxisSimRequest r = triangle_on_x("pi_notch");
    r.axis = "";
    EXPECT_EQ(test::error_of([&] { (void)plan_multi_axis_sim(x, r); }), "--axis: a stage of axes x, y, z: choose one");
    r.axis = "q";
    EXPECT_EQ(test::error_of([&] { (void)plan_multi_axis_sim(x, r); }), "--axis: must be one of the axes x, y, z (got \"q\")");
}
