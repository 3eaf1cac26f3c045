// What a scan is: the pattern, its size and timing, and the events it marks.
//
// A scan moves two axes (x, y) along a pattern about a centre, rotated by an
// angle; a third axis (z) is held. Every field is validated by
// ScanGenerator::configure(), which names the field it refuses
// (group "scan"). docs/scan.md describes the patterns.
#pragma once

#include <cstdint>

namespace piezoloop {

enum class ScanPattern : uint8_t { kRaster, kSpiral, kLissajous, kCycloid };
// The raster's slow axis: a staircase steps between lines during the
// turnaround; a ramp moves continuously over the frame.
enum class SlowAxis : uint8_t { kStaircase, kRamp };
// The raster's fast axis: constant velocity with bounded-jerk turnarounds,
// or a sinusoid.
enum class FastAxis : uint8_t { kTriangle, kSine };
// Constant angular velocity (r grows linearly in time), or constant linear
// velocity (angle ~ sqrt(t)) outside a centre region run at the turn rate.
enum class SpiralMode : uint8_t { kConstantAngularVelocity, kConstantLinearVelocity };

// The sync word: events of one tick, a bit each. An event belongs to the
// tick whose reference it comes with: that reference is the frame's first,
// the line's first, or the start of a pixel.
inline constexpr uint32_t kSyncFrameStart = 1u << 0;
inline constexpr uint32_t kSyncLineStart = 1u << 1;
inline constexpr uint32_t kSyncPixel = 1u << 2;

struct ScanConfig {
    ScanPattern pattern = ScanPattern::kRaster;
    float sample_rate_Hz = 100000.0f;  // the loop rate
    float centre_x_um = 0.0f;
    float centre_y_um = 0.0f;
    float hold_z_um = 0.0f;            // the third axis, held
    float rotation_deg = 0.0f;         // the pattern turned about the centre, [-360, 360]
    uint32_t frames = 1;               // 0 = repeat forever
    uint32_t pixels_per_line = 256;    // [1, 65536]

    // Raster and cycloid: the used area, size_x_um along the lines.
    // Lissajous: the peak-to-peak extents (amplitudes size / 2).
    float size_x_um = 10.0f;
    float size_y_um = 10.0f;
    uint32_t lines_per_frame = 256;    // raster, cycloid: [1, 65536]

    // Raster.
    float line_rate_Hz = 10.0f;        // lines per second (trace + retrace; bidirectional: each sweep)
    float retrace_speed_factor = 1.0f; // retrace speed / trace speed, [1, 16]
    float overscan_fraction = 0.05f;   // constant-velocity run beyond each end of the used width, share of it, [0, 1]
    float turnaround_s = 0.002f;       // duration of each turnaround (>= 2 ticks)
    SlowAxis slow_axis = SlowAxis::kStaircase;
    bool bidirectional = false;        // both sweeps are lines (no retrace)
    FastAxis fast_axis = FastAxis::kTriangle;  // kSine: retrace_speed_factor and turnaround_s unused

    // Spiral; the cycloid's circle uses radius_um and turn_rate_Hz too.
    SpiralMode spiral_mode = SpiralMode::kConstantAngularVelocity;
    float radius_um = 5.0f;            // spiral: outer radius; cycloid: circle radius
    uint32_t turns = 32;               // spiral: [1, 65536], pitch = radius_um / turns
    float turn_rate_Hz = 50.0f;        // turns per second (CLV: in the centre region)
    float linear_speed_um_s = 500.0f;  // CLV: tangential speed outside the centre region

    // Lissajous: x = size_x/2 sin(2 pi f_x t), y = size_y/2 sin(2 pi f_y t + phase).
    float frequency_x_Hz = 100.0f;
    float frequency_y_Hz = 99.0f;
    float phase_y_deg = 90.0f;

    // Cycloid: whole circle turns per line (the circle's centre advances
    // size_x_um / turns_per_line per turn), [1, 65536].
    uint32_t turns_per_line = 32;

    bool operator==(const ScanConfig&) const = default;
};

}  // namespace piezoloop
