// `measure frf --mimo` against the simulator: the n x n frequency response of
// a scenario's stage of coupled axes (common/piezoloop/axes/coupled_stage.hpp),
// measured with orthogonal multisines on every axis at once
// (mimo_frf_plan.hpp) and estimated from what the stage got and read
// (mimo_frf_estimate.hpp).
//
// Open loop: the plan's axis commands go through the core's channel stage
// (common/piezoloop/axes/channel_output.hpp: the output matrix, then each
// channel's hard limits and slew) to the stage's command inputs, one sample
// each; the readings divided by each sensor's gain are y (µm). The estimate
// relates y to the axis commands, so with a decoupling output matrix it is
// the response the axes' controllers see: G D.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Dense>

#include "measure/mimo_frf_estimate.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::measure {

struct MimoFrfSimRun {
    MimoFrfPlan plan;
    MimoFrfEstimate estimate;
    std::vector<uint32_t> clamped_samples;  // per channel: the hard limits acted
    std::vector<uint32_t> slew_limited_samples;
    uint64_t log_hash = 0;                  // of every tick's channel commands and readings
    double wall_s = 0.0;
};

// The request with the scenario's axis count and rate filled in; the plan
// refuses what does not fit (mimo_frf_plan.hpp). bias_V: one value for all
// axes, or one per axis. Throws std::invalid_argument naming the option.
MimoFrfRequest mimo_request(const sim::Scenario& s, double from_Hz, double to_Hz, double amplitude_V,
                            const std::vector<double>& bias_V, int periods, int transient_periods);

// output_matrix: the decoupling matrix between the axis commands and the
// channels (n x n, validated by the core: finite, |m| <= 16, 1-norm
// condition <= 1000); none: the identity.
MimoFrfSimRun run_mimo_frf_sim(const sim::Scenario& s, const MimoFrfRequest& r,
                               const std::optional<Eigen::MatrixXd>& output_matrix = std::nullopt,
                               const std::function<void(double)>& progress = {});

}  // namespace piezoloop::measure
