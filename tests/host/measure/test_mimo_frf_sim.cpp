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

// The shipped XYZ flexure with its hysteresis replaced by a linear gain: a
// linear stage, whose response the exact transfer matrix gives.
sim::Scenario linear_xyz() {
    sim::Scenario s = sim::load_scenario(kConfigs + "xyz_flexure.json");
    for (sim::AxisSpec& a : s.axes) {
        a.plant.hysteresis = sim::HysteresisSpec{};
        a.plant.hysteresis.gain_um_per_V = 0.6;
    }
    s.plant = s.axes[0].plant;
    return s;
}

MimoFrfRequest request(const sim::Scenario& s) {
    // 20 Hz spacing up to 2 kHz (past the XY modes at 750 / 850 Hz), 0.5 V
    // peak about mid-range.
    return mimo_request(s, 20.0, 2000.0, 0.5, {5.0}, 6, 2);
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
    EXPECT_GE(off_checked, 4 * 90);
    RecordProperty("worst_diagonal_db", std::to_string(worst_diag_db));
    RecordProperty("worst_diagonal_deg", std::to_string(worst_diag_deg));
    RecordProperty("worst_off_diagonal_db", std::to_string(worst_off_db));
}

// The low-frequency coupling of every coupled pair, before and after the
// static decoupling designed from the first measurement.
void expect_decoupled_by(const sim::Scenario& s, double min_reduction_db) {
    const MimoFrfSimRun before = run_mimo_frf_sim(s, request(s));
    const StaticDecoupling d = static_decoupling(before.estimate.frequency_Hz, before.estimate.response);
    const MimoFrfSimRun after = run_mimo_frf_sim(s, request(s), d.output_matrix);
    const Coupling cb = coupling(before.estimate.frequency_Hz, before.estimate.response, std::nullopt);
    const Coupling ca = coupling(after.estimate.frequency_Hz, after.estimate.response, std::nullopt);
    ASSERT_EQ(cb.pairs.size(), ca.pairs.size());
    int coupled = 0;
    for (std::size_t p = 0; p < cb.pairs.size(); ++p) {
        // The pairs the stage couples (x->y, y->x, x->z, y->z: -30..-40 dB);
        // z moves neither x nor y.
        if (!(cb.pairs[p].low_frequency_db > -60.0)) continue;
        ++coupled;
        const std::string name = "y" + std::to_string(cb.pairs[p].output + 1) + "<-u" + std::to_string(cb.pairs[p].input + 1);
        EXPECT_LE(ca.pairs[p].low_frequency_db, cb.pairs[p].low_frequency_db - min_reduction_db) << name;
        RecordProperty(name + "_db", std::to_string(cb.pairs[p].low_frequency_db) + " -> " +
                                         std::to_string(ca.pairs[p].low_frequency_db));
    }
    EXPECT_EQ(coupled, 4);
}

TEST(MimoFrfSim, StaticDecouplingCutsTheLowFrequencyCouplingOfTheLinearStage) {
    expect_decoupled_by(linear_xyz(), 20.0);
}

TEST(MimoFrfSim, StaticDecouplingCutsTheLowFrequencyCouplingOfTheShippedStage) {
    // With its hysteresis: the small-signal slopes about the bias are what the
    // decoupling matrix inverts.
    expect_decoupled_by(sim::load_scenario(kConfigs + "xyz_flexure.json"), 20.0);
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
