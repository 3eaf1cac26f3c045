// The tick's converters on the NUCLEO-H743ZI2 (see board.cpp). Inline: they
// are part of the measured tick. In loopback (self-test without a stage)
// both go to the emulated stage instead.
#pragma once

#include <array>
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

// Every axis's converters, as codes and samples: the sensor's and the
// amplifier's full scales (board_config.hpp).
inline constexpr fw::Converter16 kAdc{config::kPositionFullScale_um};
inline constexpr fw::Converter16 kDac{config::kVoltageFullScale_V};

// An ADC's data register: 16-bit unsigned, offset binary around mid-scale.
// Reading it clears the end-of-conversion flag. ADC1 is the single axis's
// (and x's); ADC2 and ADC3 convert y and z on the same trigger.
inline int32_t adc_read(uintptr_t adc) {
    const uint32_t start = stm32::reg(stm32::core::kDwtCyccnt);
    while ((stm32::reg(adc + stm32::adc::kIsr) & stm32::adc::kIsrEoc) == 0u &&
           stm32::reg(stm32::core::kDwtCyccnt) - start < kAdcWaitMax_cycles) {
    }
    return static_cast<int32_t>(stm32::reg(adc + stm32::adc::kDr) & 0xFFFFu) - 32768;
}
inline int32_t adc_read() { return adc_read(stm32::adc::kAdc1); }

// DAC1 channel 1 (channel 2: y of the three-axis image), 12-bit right
// aligned: the 16-bit code's top 12 bits, offset binary.
inline void dac_write(int32_t code) {
    stm32::reg(stm32::dac::kDhr12r1) = static_cast<uint32_t>(code + 32768) >> 4;
}
inline void dac_write2(int32_t code) {
    stm32::reg(stm32::dac::kDhr12r2) = static_cast<uint32_t>(code + 32768) >> 4;
}

// ---- the three-axis image (servo_xyz.elf) -----------------------------------
//
// x: ADC1 INP15 (PA3, Zio A0) -> DAC1 OUT1 (PA4)
// y: ADC2 INP10 (PC0, Zio A1) -> DAC1 OUT2 (PA5)
// z: ADC3 INP6 (PF10, Zio A5) -> an external 16-bit SPI DAC (the board has
//    no third DAC channel): SPI3, SCK PC10, MOSI PC12 (AF6), chip select PA15
//    as a GPIO; mode 0, MSB first, straight binary (code + 32768), latched on
//    the chip select's rising edge (AD5541A, DAC8830 and alike).

// The external DAC's frame: chip select low, the 16-bit code into the
// FIFO. A 16-bit access: a 32-bit write would queue two frames.
inline void spi_dac_start(int32_t code) {
    stm32::gpio::set(stm32::gpio::kPortA, 15, false);
    *reinterpret_cast<volatile uint16_t*>(stm32::spi3::kTxdr) = static_cast<uint16_t>(code + 32768);
}
// Chip select high once the frame is out (0.67 µs at 24 MHz after the
// start), which latches it; bounded like the ADC's wait.
inline void spi_dac_finish() {
    const uint32_t start = stm32::reg(stm32::core::kDwtCyccnt);
    while ((stm32::reg(stm32::spi3::kSr) & stm32::spi3::kSrTxc) == 0u &&
           stm32::reg(stm32::core::kDwtCyccnt) - start < kAdcWaitMax_cycles) {
    }
    stm32::gpio::set(stm32::gpio::kPortA, 15, true);
}

// Starts ADC2 (and ADC3), DAC1's channel 2 (and the SPI DAC, at mid-scale)
// and turns the data cache on (dcache.hpp); axes is 2 or 3. False, with the
// converters of the single axis untouched, if an ADC does not calibrate or
// enable, or the tick already runs.
bool converter_axes_init(int axes);

// The converters as the axes' loop sees them (app/axes_loop.hpp): every
// reading in, the pipeline's output phase, every command out; step() after
// the tick latches z's frame.
template <int N>
struct ConverterAxes {
    static_assert(N == 2 || N == 3, "the board has converters for 2 or 3 axes");

    template <class PipelineT>
    void output(PipelineT& pipe) {
        using T = fw::CoreSample;
        std::array<T, N> y{};
        y[0] = kAdc.sample_from_code<T>(adc_read(stm32::adc::kAdc1));
        y[1] = kAdc.sample_from_code<T>(adc_read(stm32::adc::kAdc2));
        if constexpr (N == 3) y[2] = kAdc.sample_from_code<T>(adc_read(stm32::adc::kAdc3));
        const auto& u = pipe.output(y);
        if constexpr (N == 3) spi_dac_start(kDac.code_from_sample(u[2]));  // first: the longest write
        dac_write(kDac.code_from_sample(u[0]));
        dac_write2(kDac.code_from_sample(u[1]));
    }
    void step() {
        if constexpr (N == 3) spi_dac_finish();
    }
};

// The tick's I/O: ADC code -> sample -> pipeline output -> DAC code on the
// real converters; in loopback the emulated stage in physical units, as on
// the QEMU boards (so the self-test's log hash is the same everywhere).
template <class T, class PipelineT>
inline void control_io(PipelineT& pipe) {
    if (stm32::g_loopback) {
        stm32::g_emulated_stage.output(pipe);
        return;
    }
    const T u = pipe.output(kAdc.sample_from_code<T>(adc_read()));
    dac_write(kDac.code_from_sample(u));
}

}  // namespace piezoloop::bsp
