// The "double" fidelity of the simulated stage: the same signal chain as
// common/piezoloop/stage_model.hpp (DAC -> amplifier -> hysteresis -> linear
// dynamics -> sensor -> noise -> ADC), but with the continuous-time parts
// integrated in double precision at `substeps` sub-steps per loop tick
// instead of discretised once at the loop rate in float.
//
// How each part is integrated:
//  - DAC: the command is quantised (same Converter as the float stage) and
//    held for the whole tick (zero-order hold), as a real DAC does.
//  - Amplifier: input clamp, gain, then its first-order bandwidth solved
//    exactly: with the held input the lag output is
//    target + (v0 - target) e^{-t/tau}; its output clamp is applied to the
//    value at each sub-step's midpoint.
//  - Hysteresis: evaluated once per sub-step on the piezo voltage at the
//    sub-step midpoint (the PI model in double; Dahl with the core's float
//    DahlActuator, which is exact per sample up to float rounding), and held
//    over the sub-step.
//  - Linear dynamics and sensor bandwidth: one continuous state space (the
//    dynamics in series with the sensor's first-order lag), discretised
//    exactly for a held input over one sub-step (ZOH: the matrix exponential
//    of [[A h, B h], [0, 0]]). So the only approximation of the continuous
//    part is holding the hysteresis output over a sub-step; it vanishes as
//    substeps grows, and is exact when the amplifier has no bandwidth limit
//    (the piezo voltage is then constant over the tick).
//  - Creep: the float stage's lags (common/piezoloop/creep.hpp, the same
//    time constants and weights) as continuous first-order lags on the
//    hysteresis output, solved exactly for it held over each sub-step.
//  - Drift: drift * t, t = (tick index since reset) / rate, as the float
//    stage.
//  - Sensor: sampled at the end of the tick, gain (1 + gain_error), then
//    offset and mains pickup (std::sin at the float stage's sample times,
//    the same phase 0 at reset) through that gain, noise from the same
//    seeded generator as the float stage, then the ADC.
// Timing is that of the float stage and of the emulated boards: step(u)
// applies u for one tick and returns the reading latched at its end.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Dense>

#include "ident/dead_zone_map.hpp"
#include "lti/lti.hpp"
#include "piezoloop/stage_model.hpp"

namespace piezoloop::sim {

// Plain PI model in double (the plant's hysteresis in the double fidelity).
class PiModelDouble {
public:
    void configure(const PiModel& m);
    void reset();
    double apply(double x);

private:
    PiModel m_{};
    std::vector<double> w_;
};

struct DoubleStageConfig {
    double rate_Hz = 100000.0;
    int substeps = 10;            // >= 1
    ConverterConfig dac{};
    AmplifierConfig amplifier{};  // bandwidth_Hz: continuous first-order lag (0: none)
    HysteresisKind hysteresis = HysteresisKind::kNone;
    PiModel pi{};
    DahlParams dahl{};
    double linear_gain_um_per_V = 1.0;
    OutputMap output_map{};       // S on the hysteresis's output (plant.hpp), in double
    std::optional<design::Ss> dynamics;  // continuous, µm -> µm; none: static
    SensorConfig sensor{};        // bandwidth_Hz: continuous first-order lag
    ConverterConfig adc{};
    CreepConfig creep{};
    double drift_um_per_s = 0.0;
};

class DoubleStage {
public:
    // Throws std::invalid_argument naming the field for invalid settings.
    void configure(const DoubleStageConfig& c);
    void reset();
    // One tick: command (V) in, ADC reading (sensor units) out.
    float step(float u_V);
    double piezo_voltage_V() const { return v_piezo_; }
    double displacement_um() const { return x_um_; }

private:
    double hysteresis(double v);

    DoubleStageConfig c_{};
    Converter dac_{}, adc_{};
    SeededNoise noise_{};
    PiModelDouble pi_{};
    DahlActuator dahl_{};
    double amp_decay_half_ = 0.0;  // e^{-h/(2 tau)}, 0 without bandwidth
    double amp_decay_full_ = 0.0;  // e^{-h/tau}
    double v_amp_ = 0.0;           // amplifier lag state (before the output clamp)
    double v_piezo_ = 0.0, x_um_ = 0.0;
    CreepLags creep_{};
    std::vector<double> creep_decay_, creep_state_;  // e^{-h/tau_k}, lag outputs
    double creep_scale_ = 0.0;                        // p / 100
    double sensor_gain_ = 1.0;                        // gain (1 + gain_error)
    uint64_t ticks_ = 0;                              // since reset
    // Sub-step ZOH model of dynamics + sensor lag.
    design::DeadZoneMap output_map_;  // c_.output_map in double
    Eigen::MatrixXd ad_;
    Eigen::VectorXd bd_;
    Eigen::RowVectorXd c_out_;
    double d_out_ = 0.0;
    Eigen::RowVectorXd c_disp_;  // displacement (the dynamics' output)
    double d_disp_ = 0.0;
    Eigen::VectorXd x_, x_next_;
    bool has_states_ = false;
};

}  // namespace piezoloop::sim
