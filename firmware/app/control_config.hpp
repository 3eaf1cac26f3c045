// What the firmware's control loop is built from: the pipeline type, its
// setup (the board's converters and hard limits), the recorder selection.
// Shared with the host build of the self-test (tests/firmware/), which must
// run the identical pipeline to reproduce the board's log hash.
#pragma once

#include <cstdint>

#include "bsp/converter16.hpp"
#include "piezoloop/limits.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/recorder.hpp"
#include "piezoloop/sample.hpp"

namespace piezoloop::fw {

inline constexpr float kLoopRate_Hz = 100000.0f;
inline constexpr uint32_t kLoopRateInt_Hz = 100000;

// RC delay line: N up to 2048 (the reference N = 100; a 50 Hz raster's
// line at 100 kHz is 2000 ticks; a reconfiguration copies only N of them,
// delay_line.hpp); recorder: four
// channels, what the host's link client records (r, y, e, u; the log hash
// covers r, y, u), PIEZOLOOP_RECORDER_CAPACITY frames of slack for the main
// loop that drains it into log blocks (firmware/CMakeLists.txt: 4096 =
// 41 ms at 100 kHz on the QEMU boards, whose UART keeps up with the full
// stream; 512 in the STM32's 128 KiB DTCM); setpoint FIFO of the link's stream.
#ifndef PIEZOLOOP_RECORDER_CAPACITY
#define PIEZOLOOP_RECORDER_CAPACITY 4096
#endif
#ifndef PIEZOLOOP_EXCITATION_CAPACITY
#define PIEZOLOOP_EXCITATION_CAPACITY 1024
#endif
inline constexpr int kRcCapacity = 2048;
inline constexpr std::size_t kRecChannels = 4;
// A board of axes streams its board recorder: eight (axis, signal) channels
// (r and y of three axes and two more, at the loop rate on the QEMU boards).
inline constexpr std::size_t kBoardRecChannels = 8;
inline constexpr std::size_t kRecCapacity = PIEZOLOOP_RECORDER_CAPACITY;
inline constexpr std::size_t kSetpointCapacity = 1024;
inline constexpr std::size_t kExcCapacity = PIEZOLOOP_EXCITATION_CAPACITY;

template <class T>
using FwPipeline = Pipeline<T, kRcCapacity, kRecChannels, kRecCapacity, kExcCapacity>;

// The board's side of the pipeline: hard limits and converter full scales
// are facts of the hardware (bsp/<board>/board_config.hpp), given once.
struct BoardAnalog {
    HardLimits hard;
    float position_full_scale_um;
    float voltage_full_scale_V;
};

constexpr PipelineSetup pipeline_setup(const BoardAnalog& b, float rate_Hz = kLoopRate_Hz) {
    PipelineSetup s{};
    s.hard = b.hard;
    s.rate_Hz = rate_Hz;
    s.position = SignalScale{b.position_full_scale_um};
    s.voltage = SignalScale{b.voltage_full_scale_V};
    return s;
}

// Frames {r, y, u, e}: the log hash is over the first three.
template <class T>
constexpr RecorderConfig<kRecChannels> log_recorder_config() {
    RecorderConfig<kRecChannels> c{};
    c.channels = {signal_index(SignalId::kR), signal_index(SignalId::kY), signal_index(SignalId::kU),
                  signal_index(SignalId::kE)};
    c.decimation = 1;
    c.mode = RecordMode::kContinuous;
    c.trigger = TriggerMode::kImmediate;
    return c;
}

// One control step as the tick does it: ADC code in, DAC code out.
template <class T, class PipelineT>
inline int32_t control_step(PipelineT& pipe, const Converter16& adc, const Converter16& dac, int32_t adc_code) {
    const T u = pipe.tick(adc.sample_from_code<T>(adc_code));
    return dac.code_from_sample(u);
}

}  // namespace piezoloop::fw
