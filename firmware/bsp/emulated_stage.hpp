// The stage of a board without converters: the DAC drives the plant model
// of common/ (HammersteinPlant, the one the host simulator runs), and the
// ADC samples its displacement. Both converters are 16-bit (converter16.hpp)
// over the board's full scales.
//
// Timing, as on a real board whose ADC is sampled at the tick: the tick
// reads the code latched at the end of the previous period, computes, and
// writes the DAC; step() then advances the plant by one sample with that DAC
// voltage and latches the new displacement for the next tick. So the loop
// has one sample of compute delay, like reference_run.hpp's loop.
//
// Header-only and free of board code: the host builds the very same class
// to compute the self-test's expected log hash (tests/firmware/).
#pragma once

#include <cstdint>

#include "bsp/converter16.hpp"
#include "piezoloop/plant.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop::fw {

class EmulatedStage {
public:
    constexpr EmulatedStage(float position_full_scale_um, float voltage_full_scale_V)
        : adc_(position_full_scale_um), dac_(voltage_full_scale_V) {}

    // Not concurrent with step(): call with the control timer stopped.
    Status configure(const PlantConfig& c) {
        if (const Status s = plant_.configure(c); !s.ok()) return s;
        reset();
        return ok_status();
    }
    // Stage at rest, DAC at 0 V.
    void reset() {
        plant_.reset();
        dac_code_ = 0;
        adc_code_ = adc_.code_from_physical(0.0f);
    }

    int32_t adc_code() const { return adc_code_; }
    void dac_write(int32_t code) { dac_code_ = code; }
    int32_t dac_code() const { return dac_code_; }

    // One sample of physics: the plant sees the DAC voltage; the ADC
    // latches its displacement.
    void step() {
        const float y_um = plant_.step(dac_.physical_from_code(dac_code_));
        adc_code_ = adc_.code_from_physical(y_um);
    }

    const Converter16& adc() const { return adc_; }
    const Converter16& dac() const { return dac_; }
    const HammersteinPlant& plant() const { return plant_; }

private:
    Converter16 adc_;
    Converter16 dac_;
    HammersteinPlant plant_{};
    int32_t adc_code_ = 0;
    int32_t dac_code_ = 0;
};

}  // namespace piezoloop::fw
