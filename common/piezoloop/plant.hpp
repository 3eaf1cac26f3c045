// Simulated piezo stage: a Hammerstein model, docs/models.md, 'Stages and scenarios' — a static hysteresis
// (PI model, or Dahl solved per sample) feeding linear dynamics realised as a
// biquad cascade with unit DC gain. The host simulator, the `piezoloop demo`
// and the emulated boards all run this one implementation, so they agree bit
// for bit. Float only: it models physics, not the controller.
#pragma once

#include <array>
#include <cstdint>

#include "piezoloop/biquad.hpp"
#include "piezoloop/dahl.hpp"
#include "piezoloop/pi_model.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

inline constexpr int kMaxPlantSections = 6;

enum class HysteresisKind : uint8_t { kNone = 0, kPi, kDahl };

struct PlantConfig {
    HysteresisKind hysteresis = HysteresisKind::kNone;
    PiModel pi{};                // kPi: V -> µm, static
    DahlParams dahl{};           // kDahl: V -> µm
    float linear_gain_um_per_V = 1.0f;  // kNone: static gain
    int sections = 0;            // 0: no dynamics
    std::array<SosSection, kMaxPlantSections> dynamics{};  // at the loop rate
};

class HammersteinPlant {
public:
    Status configure(const PlantConfig& c) {
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
        if (c.sections < 0 || c.sections > kMaxPlantSections)
            return error("sections", "must be in [0, 6]");
        BiquadCascade<float, kMaxPlantSections> dyn;
        if (c.sections > 0) {
            // A stage model: DF2T wherever its coefficients hold (biquad.hpp).
            if (const Status s = dyn.configure(c.dynamics.data(), c.sections, {}, {}, FormChoice::kCoefficients);
                !s.ok())
                return in_group("dynamics", s);
        }
        config_ = c;
        dynamics_ = dyn;
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
        static_um_ = 0.0f;
    }

    // One sample: voltage on the piezo in, displacement out.
    float step(float v_V) {
        switch (config_.hysteresis) {
            case HysteresisKind::kPi: static_um_ = pi_.apply(v_V); break;
            case HysteresisKind::kDahl: static_um_ = dahl_.step(v_V); break;
            case HysteresisKind::kNone: static_um_ = config_.linear_gain_um_per_V * v_V; break;
        }
        return config_.sections > 0 ? dynamics_.apply(static_um_) : static_um_;
    }

    // Output of the hysteresis alone (before the dynamics), last sample.
    float static_displacement_um() const { return static_um_; }
    const PlantConfig& config() const { return config_; }

private:
    PlantConfig config_{};
    PiOperator<float> pi_{};
    DahlActuator dahl_{};
    BiquadCascade<float, kMaxPlantSections> dynamics_{};
    float static_um_ = 0.0f;
};

}  // namespace piezoloop
