// The n x n frequency response measured on the simulator's stage of coupled
// axes (host/measure/mimo_frf_sim.cpp) against the scenario's exact sampled
// transfer matrix (host/sim/exact_transfer.cpp, itself checked against scipy
// in test_exact_transfer.cpp), and the static decoupling measured back.
#include "measure/mimo_frf_sim.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <string>

#include "measure/coupling.hpp"
#include "measure/static_decoupling.hpp"
#include "sim/exact_transfer.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::measure {
namespace {

const std::string kConfigs = std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../configs/stages/";

// The shipped XYZ flexure with its hysteresis replaced by a linear gain near
// its loading slope (x, y 0.6 µm/V, z 0.1 µm/V of piezo voltage): a linear
// stage, whose response the exact transfer matrix gives.
sim::Scenario linear_xyz() {
    sim::Scenario s = sim::load_scenario(kConfigs + "xyz_flexure.json");
    for (sim::AxisSpec& a : s.axes) {
        a.plant.hysteresis = sim::HysteresisSpec{};
        a.plant.hysteresis.gain_um_per_V = a.name == "z" ? 0.1 : 0.6;
    }
    s.plant = s.axes[0].plant;
    return s;
}

// 20 Hz spacing up to 2 kHz (past the XY modes at 750 / 850 Hz), about
// mid-range.
MimoFrfRequest request(const sim::Scenario& s, double amplitude_V = 0.5) {
    return mimo_request(s, 20.0, 2000.0, amplitude_V, {5.0}, 6, 2);
}

double db(double x) { return 20.0 * std::log10(x); }

TEST(MimoFrfSim, LinearStageMatchesTheExactTransferMatrix) {
    const sim::Scenario s = linear_xyz();
    const MimoFrfSimRun run = run_mimo_frf_sim(s, request(s));
    const MimoFrfEstimate& e = run.estimate;
    ASSERT_EQ(e.inputs, 3);
    for (uint32_t c : run.clamped_samples) EXPECT_EQ(c, 0u);
    int diagonal_checked = 0, off_checked = 0;
    double worst_diag_db = 0.0, worst_diag_deg = 0.0, worst_off_db = 0.0;
    for (std::size_t k = 0; k < e.frequency_Hz.size(); ++k) {
        const sim::TransferMatrix g = sim::exact_transfer_matrix(s, e.frequency_Hz[k]);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                const std::complex<double> m = e.response[k](i, j);
                const std::complex<double> x = g[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
                const double err_db = std::abs(db(std::abs(m) / std::abs(x)));
                if (i == j) {
                    // The tolerance on lines with SNR >= 40 dB: 0.5 dB and 3 degrees.
                    if (e.snr_db[k](i, j) < 40.0) continue;
                    const double err_deg = std::abs(std::arg(m / x)) * 180.0 / std::numbers::pi;
                    EXPECT_LE(err_db, 0.5) << "G" << i + 1 << j + 1 << " at " << e.frequency_Hz[k] << " Hz";
                    EXPECT_LE(err_deg, 3.0) << "G" << i + 1 << j + 1 << " at " << e.frequency_Hz[k] << " Hz";
                    worst_diag_db = std::max(worst_diag_db, err_db);
                    worst_diag_deg = std::max(worst_diag_deg, err_deg);
                    ++diagonal_checked;
                } else {
                    // Off-diagonal terms above -40 dB of their column's diagonal: 1 dB.
                    const std::complex<double> xjj = g[static_cast<std::size_t>(j)][static_cast<std::size_t>(j)];
                    if (db(std::abs(x) / std::abs(xjj)) < -40.0) continue;
                    EXPECT_LE(err_db, 1.0) << "G" << i + 1 << j + 1 << " at " << e.frequency_Hz[k] << " Hz";
                    worst_off_db = std::max(worst_off_db, err_db);
                    ++off_checked;
                }
            }
    }
    // Not vacuous: nearly every diagonal line, and the coupled pairs' lines.
    EXPECT_GE(diagonal_checked, 3 * 90);
    EXPECT_GE(off_checked, 4 * 50);
    RecordProperty("worst_diagonal_db", std::to_string(worst_diag_db));
    RecordProperty("worst_diagonal_deg", std::to_string(worst_diag_deg));
    RecordProperty("worst_off_diagonal_db", std::to_string(worst_off_db));
}

// The low-frequency coupling of every pair the stage couples (its coupling
// paths), before and after the static decoupling designed from the first
// measurement.
void expect_decoupled_by(const sim::Scenario& s, double amplitude_V, double min_reduction_db) {
    const MimoFrfSimRun before = run_mimo_frf_sim(s, request(s, amplitude_V));
    const StaticDecoupling d = static_decoupling(before.estimate.frequency_Hz, before.estimate.response);
    const MimoFrfSimRun after = run_mimo_frf_sim(s, request(s, amplitude_V), d.output_matrix);
    const Coupling cb = coupling(before.estimate.frequency_Hz, before.estimate.response, std::nullopt);
    const Coupling ca = coupling(after.estimate.frequency_Hz, after.estimate.response, std::nullopt);
    ASSERT_EQ(cb.pairs.size(), ca.pairs.size());
    ASSERT_EQ(s.coupling.size(), 4u);
    for (const sim::CouplingSpec& path : s.coupling) {
        const std::string name = path.to + "<-" + path.from;
        bool found = false;
        for (std::size_t p = 0; p < cb.pairs.size(); ++p) {
            if (cb.pairs[p].output != path.to_axis || cb.pairs[p].input != path.from_axis) continue;
            found = true;
            // The paths are 1-3 % of the source's displacement (-40..-30 dB):
            // the measurement sees them before decoupling.
            EXPECT_GT(cb.pairs[p].low_frequency_db, -45.0) << name;
            EXPECT_LE(ca.pairs[p].low_frequency_db, cb.pairs[p].low_frequency_db - min_reduction_db) << name;
            ::testing::Test::RecordProperty(name + "_db", std::to_string(cb.pairs[p].low_frequency_db) + " -> " +
                                                             std::to_string(ca.pairs[p].low_frequency_db));
        }
        EXPECT_TRUE(found) << name;
    }
}

TEST(MimoFrfSim, StaticDecouplingCutsTheLowFrequencyCouplingOfTheLinearStage) {
    expect_decoupled_by(linear_xyz(), 0.5, 20.0);
}

TEST(MimoFrfSim, StaticDecouplingCutsTheLowFrequencyCouplingOfTheShippedStage) {
    // With its hysteresis, at 0.1 V: the small-signal slopes about the bias
    // are what the decoupling matrix inverts. At 0.5 V the hysteresis'
    // distortion, on the lines of every input at once, reads as a y <- z
    // coupling of -16 dB that the stage does not have (docs/measurement.md).
    expect_decoupled_by(sim::load_scenario(kConfigs + "xyz_flexure.json"), 0.1, 20.0);
}

TEST(MimoFrfSim, RefusesWhatItCannotMeasure) {
    const sim::Scenario s = linear_xyz();
    auto message = [](auto&& f) {
        try {
            f();
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("(no error)");
    };
    EXPECT_EQ(message([&] { (void)mimo_request(s, 20.0, 2000.0, 6.0, {5.0}, 6, 2); }).rfind("--amplitude-v:", 0), 0u);
    EXPECT_EQ(message([&] { (void)mimo_request(s, 20.0, 2000.0, 0.5, {5.0, 5.0}, 6, 2); }).rfind("--bias-v:", 0), 0u);
    Eigen::MatrixXd singular = Eigen::MatrixXd::Ones(3, 3);
    EXPECT_EQ(message([&] { (void)run_mimo_frf_sim(s, request(s), singular); }).rfind("--output-matrix:", 0), 0u);
    EXPECT_EQ(message([&] { (void)run_mimo_frf_sim(s, request(s), Eigen::MatrixXd::Identity(2, 2)); })
                  .rfind("--output-matrix:", 0),
              0u);
    const sim::Scenario one = sim::load_scenario(kConfigs + "stiff_stack.json");
    EXPECT_EQ(message([&] { (void)mimo_request(one, 20.0, 2000.0, 0.5, {5.0}, 6, 2); }).rfind("--mimo:", 0), 0u);
}

}  // namespace
}  // namespace piezoloop::measure
