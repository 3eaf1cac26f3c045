#include "sim/stage_double.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "lti/c2d.hpp"

#include "status_text.hpp"

namespace piezoloop::sim {

void PiModelDouble::configure(const PiModel& m) {
    m_ = m;
    w_.assign(static_cast<size_t>(m.count), 0.0);
}

void PiModelDouble::reset() { std::fill(w_.begin(), w_.end(), 0.0); }

double PiModelDouble::apply(double x) {
    const double f = static_cast<double>(m_.input_gain) * x + static_cast<double>(m_.input_offset);
    double y = static_cast<double>(m_.p0) * f;
    for (int j = 0; j < m_.count; ++j) {
        const size_t i = static_cast<size_t>(j);
        const double r = m_.thresholds[i];
        w_[i] = std::max(f - r, std::min(f + r, w_[i]));
        y += static_cast<double>(m_.weights[i]) * w_[i];
    }
    return y;
}

namespace {

[[noreturn]] void fail(const char* group, const Status& s) {
    std::string text = "double stage: ";
    text += group;
    text += ".";
    text += describe(s);
    throw std::invalid_argument(text);
}

}  // namespace

void DoubleStage::configure(const DoubleStageConfig& c) {
    if (!(c.rate_Hz > 0.0) || !std::isfinite(c.rate_Hz))
        throw std::invalid_argument("double stage: rate_Hz: must be finite and > 0");
    if (c.substeps < 1 || c.substeps > 10000)
        throw std::invalid_argument("double stage: substeps: must be in [1, 10000]");
    if (const Status s = dac_.configure(c.dac); !s.ok()) fail("dac", s);
    if (const Status s = adc_.configure(c.adc); !s.ok()) fail("adc", s);
    if (!(c.amplifier.bandwidth_Hz >= 0.0f) || !(c.sensor.bandwidth_Hz >= 0.0f))
        throw std::invalid_argument("double stage: bandwidth_Hz: must be >= 0");
    switch (c.hysteresis) {
        case HysteresisKind::kPi:
            if (const Status s = validate(c.pi); !s.ok()) fail("pi", s);
            pi_.configure(c.pi);
            break;
        case HysteresisKind::kDahl:
            if (const Status s = dahl_.configure(c.dahl); !s.ok()) fail("dahl", s);
            break;
        case HysteresisKind::kNone:
            break;
    }
    if (const Status s = validate(c.output_map); !s.ok()) fail("plant", s);
    if (const Status s = creep_lags(c.creep, creep_); !s.ok()) fail("plant.creep", s);
    {
        MainsPickup probe;
        if (const Status s = probe.configure(c.sensor.mains, static_cast<float>(c.rate_Hz)); !s.ok())
            fail("sensor.mains", s);
    }
    if (!std::isfinite(c.drift_um_per_s)) throw std::invalid_argument("double stage: plant.drift_um_per_s: must be finite");
    c_ = c;
    output_map_ = design::dead_zone_map(c.output_map);
    const double h = 1.0 / (c.rate_Hz * c.substeps);
    creep_decay_.assign(static_cast<size_t>(creep_.count), 0.0);
    for (int k = 0; k < creep_.count; ++k)
        creep_decay_[static_cast<size_t>(k)] = std::exp(-h / creep_.tau_s[static_cast<size_t>(k)]);
    creep_state_.assign(static_cast<size_t>(creep_.count), 0.0);
    creep_scale_ = static_cast<double>(c.creep.percent_per_decade) / 100.0;
    sensor_gain_ = static_cast<double>(c.sensor.gain) * (1.0 + static_cast<double>(c.sensor.gain_error));
    if (c.amplifier.bandwidth_Hz > 0.0f) {
        const double w = 2.0 * M_PI * c.amplifier.bandwidth_Hz;
        amp_decay_half_ = std::exp(-0.5 * w * h);
        amp_decay_full_ = std::exp(-w * h);
    } else {
        amp_decay_half_ = amp_decay_full_ = 0.0;
    }

    // Continuous model of the dynamics followed by the sensor's lag.
    Eigen::MatrixXd a(0, 0);
    Eigen::VectorXd b(0);
    Eigen::RowVectorXd cc(0);
    double d = 1.0;
    if (c.dynamics) {
        const design::Ss& s = *c.dynamics;
        if (design::is_discrete(s.ts)) throw std::invalid_argument("double stage: dynamics: must be continuous");
        a = s.A;
        b = s.B;
        cc = s.C;
        d = s.D;
    }
    Eigen::RowVectorXd c_disp = cc;  // the displacement, before the sensor
    const double d_disp = d;
    if (c.sensor.bandwidth_Hz > 0.0f) {
        c_disp.conservativeResize(cc.size() + 1);
        c_disp(cc.size()) = 0.0;
        const double w = 2.0 * M_PI * c.sensor.bandwidth_Hz;
        const Eigen::Index n = a.rows();
        Eigen::MatrixXd a2 = Eigen::MatrixXd::Zero(n + 1, n + 1);
        a2.topLeftCorner(n, n) = a;
        a2.block(n, 0, 1, n) = w * cc;
        a2(n, n) = -w;
        Eigen::VectorXd b2(n + 1);
        b2.head(n) = b;
        b2(n) = w * d;
        Eigen::RowVectorXd c2 = Eigen::RowVectorXd::Zero(n + 1);
        c2(n) = 1.0;
        a = a2;
        b = b2;
        cc = c2;
        d = 0.0;
    }
    const Eigen::Index n = a.rows();
    has_states_ = n > 0;
    if (has_states_) {
        // Exact for an input held over the sub-step (lti/c2d: ZOH).
        design::Ss cont;
        cont.A = a;
        cont.B = b;
        cont.C = cc;
        cont.D = d;
        const design::Ss disc = design::zoh(cont, h);
        ad_ = disc.A;
        bd_ = disc.B;
        if (!ad_.allFinite() || !bd_.allFinite())
            throw std::invalid_argument("double stage: dynamics: the sub-step ZOH model is not finite");
    }
    c_out_ = cc;
    d_out_ = d;
    c_disp_ = c_disp;
    d_disp_ = d_disp;
    x_ = Eigen::VectorXd::Zero(n);
    x_next_ = Eigen::VectorXd::Zero(n);
    reset();
}

void DoubleStage::reset() {
    pi_.reset();
    dahl_.reset(0.0f);
    noise_.seed(c_.sensor.seed);
    v_amp_ = v_piezo_ = x_um_ = 0.0;
    x_.setZero();
    std::fill(creep_state_.begin(), creep_state_.end(), 0.0);
    ticks_ = 0;
}

double DoubleStage::hysteresis(double v) {
    double x = c_.linear_gain_um_per_V * v;
    switch (c_.hysteresis) {
        case HysteresisKind::kPi: x = pi_.apply(v); break;
        case HysteresisKind::kDahl: x = dahl_.step(static_cast<float>(v)); break;
        case HysteresisKind::kNone: break;
    }
    return output_map_.apply(x);
}

float DoubleStage::step(float u_V) {
    const AmplifierConfig& a = c_.amplifier;
    double v_in = dac_.apply(u_V);
    v_in = std::clamp(v_in, static_cast<double>(a.input_min_V), static_cast<double>(a.input_max_V));
    const double target = static_cast<double>(a.gain) * v_in;
    const double lo = a.output_min_V, hi = a.output_max_V;
    double s = 0.0;  // hysteresis output held over the sub-step
    for (int k = 0; k < c_.substeps; ++k) {
        const double v_mid = target + (v_amp_ - target) * amp_decay_half_;
        v_amp_ = target + (v_amp_ - target) * amp_decay_full_;
        v_piezo_ = std::clamp(v_mid, lo, hi);
        s = hysteresis(v_piezo_);
        if (creep_.count > 0) {
            // Each lag solved exactly for s held over the sub-step; the
            // creep they add is that at the sub-step's end.
            double creep = 0.0;
            for (size_t i = 0; i < creep_state_.size(); ++i) {
                creep_state_[i] = s + (creep_state_[i] - s) * creep_decay_[i];
                creep += creep_.weight[i] * creep_state_[i];
            }
            s += creep_scale_ * creep;
        }
        if (has_states_) {
            x_next_.noalias() = ad_ * x_;
            x_next_ += bd_ * s;
            x_.swap(x_next_);
        }
    }
    const double t_s = static_cast<double>(ticks_) / c_.rate_Hz;  // this tick's start, as the float stage
    ++ticks_;
    const double drift = c_.drift_um_per_s * t_s;  // after the sensor lag here: a ramp lags it by its tau, < 1 pm
    x_um_ = (has_states_ ? c_disp_.dot(x_) + d_disp_ * s : s) + drift;
    const double sensed = (has_states_ ? c_out_.dot(x_) + d_out_ * s : s) + drift;
    double pickup = static_cast<double>(c_.sensor.offset_um);
    const MainsConfig& mains = c_.sensor.mains;
    for (int k = 1; k <= mains.count; ++k)
        pickup += static_cast<double>(mains.amplitudes_um[static_cast<size_t>(k - 1)]) *
                  std::sin(2.0 * M_PI * k * static_cast<double>(mains.frequency_Hz) * t_s);
    const double reading = sensor_gain_ * (sensed + pickup);
    float out = static_cast<float>(reading);
    if (c_.sensor.noise_rms > 0.0f) out = out + c_.sensor.noise_rms * noise_.next_unit();
    return adc_.apply(out);
}

}  // namespace piezoloop::sim
