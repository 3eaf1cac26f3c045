// The tick's converters on the NUCLEO-H743ZI2 (see board.cpp). Inline: they
// are part of the measured tick. In loopback (self-test without a stage)
// both go to the emulated stage instead.
#pragma once

#include <cstdint>

#include "app/core_sample.hpp"
#include "board_config.hpp"
#include "bsp/converter16.hpp"
#include "bsp/stm32h743/regs.hpp"
#include "piezoloop/emulated_stage.hpp"

namespace piezoloop::bsp {

namespace stm32 {
extern EmulatedStage<fw::CoreSample> g_emulated_stage;  // board.cpp
extern bool g_loopback;
}  // namespace stm32

// The conversion TIM6's TRGO started at this period's edge: about 0.5 µs
// (8.5 + 8.5 cycles of the 32 MHz ADC clock), which the tick spends on the
// pipeline's begin_tick, so the wait here is short or none. Bounded by one
// tick period: a conversion that never ends makes the tick late, which the
// tick monitor counts (and the data register still holds the previous
// sample).
inline constexpr uint32_t kAdcWaitMax_cycles = config::kCpuClock_Hz / 100'000u;

// ADC1 data register: 16-bit unsigned, offset binary around mid-scale.
// Reading it clears the end-of-conversion flag.
inline int32_t adc_read() {
    const uint32_t start = stm32::reg(stm32::core::kDwtCyccnt);
    while ((stm32::reg(stm32::adc::kAdc1 + stm32::adc::kIsr) & stm32::adc::kIsrEoc) == 0u &&
           stm32::reg(stm32::core::kDwtCyccnt) - start < kAdcWaitMax_cycles) {
    }
    return static_cast<int32_t>(stm32::reg(stm32::adc::kAdc1 + stm32::adc::kDr) & 0xFFFFu) - 32768;
}

// DAC1 channel 1, 12-bit right aligned: the 16-bit code's top 12 bits,
// offset binary.
inline void dac_write(int32_t code) {
    stm32::reg(stm32::dac::kDhr12r1) = static_cast<uint32_t>(code + 32768) >> 4;
}

// The tick's I/O: ADC code -> sample -> pipeline output -> DAC code on the
// real converters; in loopback the emulated stage in physical units, as on
// the QEMU boards (so the self-test's log hash is the same everywhere).
template <class T, class PipelineT>
inline void control_io(PipelineT& pipe) {
    if (stm32::g_loopback) {
        stm32::g_emulated_stage.output(pipe);
        return;
    }
    constexpr fw::Converter16 kAdc{config::kPositionFullScale_um};
    constexpr fw::Converter16 kDac{config::kVoltageFullScale_V};
    const T u = pipe.output(kAdc.sample_from_code<T>(adc_read()));
    dac_write(kDac.code_from_sample(u));
}

}  // namespace piezoloop::bsp
