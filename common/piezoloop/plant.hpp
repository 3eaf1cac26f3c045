// Simulated piezo stage: a Hammerstein model, docs/models.md, 'Stages and scenarios' — a static hysteresis
// (PI model, or Dahl solved per sample) and its optional output map (the
// modified PI's S: an asymmetric loop), optionally followed by logarithmic
// creep (creep.hpp), feeding linear dynamics realised as a biquad cascade
// with unit DC gain; optionally a thermal drift ramp on the displacement.
// The host simulator, the `piezoloop demo` and the emulated boards all run
// this one implementation, so they agree bit for bit. Float only: it models
// physics, not the controller.
#pragma once

#include <array>
#include <cstdint>

#include "piezoloop/biquad.hpp"
#include "piezoloop/creep.hpp"
#include "piezoloop/dahl.hpp"
#include "piezoloop/pi_model.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

inline constexpr int kMaxPlantSections = 6;

enum class HysteresisKind : uint8_t { kNone = 0, kPi, kDahl };

// The output map S on the hysteresis's output, µm -> µm, of Kuhnen's
// modified PI y = S(PI[v]) (Eur. J. Control 9(4), 2003):
//     S(x) = x + sum_i weights[i] * max(x - thresholds_um[i], 0),
// increasing. A loading curve S bends is not a PI model's: its ascending
// and descending branches are no longer point-symmetric. count 0: S(x) = x.
struct OutputMap {
    int count = 0;
    std::array<float, kMaxDeadZones> thresholds_um{};
    std::array<float, kMaxDeadZones> weights{};
};

// Errors name "output_map.count", "output_map.thresholds_um" or
// "output_map.weights" (with the index).
constexpr Status validate(const OutputMap& m) {
    return validate_dead_zones(m.count, m.thresholds_um, m.weights,
                               {"output_map.count", "output_map.thresholds_um", "output_map.weights",
                                "must keep the output map increasing: 1 + the weights up to it > 0"});
}

struct PlantConfig {
    HysteresisKind hysteresis = HysteresisKind::kNone;
    PiModel pi{};                // kPi: V -> µm, static
    DahlParams dahl{};           // kDahl: V -> µm
    float linear_gain_um_per_V = 1.0f;  // kNone: static gain
    OutputMap output_map{};      // on the hysteresis's output (any kind); off by default
    int sections = 0;            // 0: no dynamics
    std::array<SosSection, kMaxPlantSections> dynamics{};  // at the loop rate
    CreepConfig creep{};         // on the hysteresis output; off by default
    float drift_um_per_s = 0.0f; // thermal drift: displacement += drift * t since reset
};

class HammersteinPlant {
public:
    // rate_Hz: the sample rate, needed only by creep and drift (0: unknown,
    // and both must then be off).
    Status configure(const PlantConfig& c, float rate_Hz = 0.0f) {
        switch (c.hysteresis) {
            case HysteresisKind::kNone:
                if (!is_finite(c.linear_gain_um_per_V))
                    return error("linear_gain_um_per_V", "must be finite");
                break;
            case HysteresisKind::kPi:
                if (const Status s = validate(c.pi); !s.ok()) return in_group("pi", s);
                break;
            case HysteresisKind::kDahl:
                if (const Status s = validate(c.dahl); !s.ok()) return in_group("dahl", s);
                break;
            default:
                return error("hysteresis", "must be none, pi or dahl");
        }
        if (const Status s = validate(c.output_map); !s.ok()) return s;
        if (c.sections < 0 || c.sections > kMaxPlantSections)
            return error("sections", "must be in [0, 6]");
        BiquadCascade<float, kMaxPlantSections> dyn;
        if (c.sections > 0) {
            // A stage model: DF2T wherever its coefficients hold (biquad.hpp).
            if (const Status s = dyn.configure(c.dynamics.data(), c.sections, {}, {}, FormChoice::kCoefficients);
                !s.ok())
                return in_group("dynamics", s);
        }
        const bool timed = c.creep.percent_per_decade != 0.0f || c.drift_um_per_s != 0.0f;
        if (timed && !(is_finite(rate_Hz) && rate_Hz > 0.0f))
            return error(c.creep.percent_per_decade != 0.0f ? "creep" : "drift_um_per_s", "needs the sample rate");
        CreepBank creep;
        if (Status s = creep.configure(c.creep, rate_Hz); !s.ok()) {
            s.field = s.field[0] == 'p' ? "creep.percent_per_decade" : (s.field[0] == 'f' ? "creep.from_s" : "creep.to_s");
            return s;
        }
        if (!is_finite(c.drift_um_per_s) || c.drift_um_per_s < -10.0f || c.drift_um_per_s > 10.0f)
            return error("drift_um_per_s", "must be finite and in [-10, 10] um/s");
        config_ = c;
        dynamics_ = dyn;
        creep_ = creep;
        drift_um_per_sample_ = timed ? static_cast<float>(static_cast<double>(c.drift_um_per_s) / rate_Hz) : 0.0f;
        // Validated above, so these cannot fail.
        if (c.hysteresis == HysteresisKind::kPi) (void)pi_.configure(c.pi);
        if (c.hysteresis == HysteresisKind::kDahl) (void)dahl_.configure(c.dahl);
        reset();
        return ok_status();
    }

    void reset() {
        pi_.reset();
        dahl_.reset(0.0f);
        dynamics_.reset();
        creep_.reset();
        static_um_ = 0.0f;
        samples_ = 0u;
    }

    // One sample: voltage on the piezo in, displacement out.
    float step(float v_V) {
        switch (config_.hysteresis) {
            case HysteresisKind::kPi: static_um_ = pi_.apply(v_V); break;
            case HysteresisKind::kDahl: static_um_ = dahl_.step(v_V); break;
            case HysteresisKind::kNone: static_um_ = config_.linear_gain_um_per_V * v_V; break;
        }
        if (config_.output_map.count > 0)
            static_um_ = dead_zone_sum(config_.output_map.count, config_.output_map.thresholds_um,
                                       config_.output_map.weights, static_um_);
        const float crept = creep_.enabled() ? creep_.apply(static_um_) : static_um_;
        const float x = config_.sections > 0 ? dynamics_.apply(crept) : crept;
        if (config_.drift_um_per_s == 0.0f) return x;
        // t = n / rate, n the samples before this one since reset (exact
        // as a float up to 2^24 samples).
        const float drift = drift_um_per_sample_ * static_cast<float>(samples_);
        ++samples_;
        return x + drift;
    }

    // Output of the hysteresis and its output map (before creep and
    // dynamics), last sample.
    float static_displacement_um() const { return static_um_; }
    // The creep added to it, last sample (0 without creep).
    float creep_um() const { return creep_.creep_um(); }
    const PlantConfig& config() const { return config_; }

private:
    PlantConfig config_{};
    PiOperator<float> pi_{};
    DahlActuator dahl_{};
    BiquadCascade<float, kMaxPlantSections> dynamics_{};
    CreepBank creep_{};
    float static_um_ = 0.0f;
    float drift_um_per_sample_ = 0.0f;
    uint32_t samples_ = 0u;  // since reset, for the drift
};

}  // namespace piezoloop
