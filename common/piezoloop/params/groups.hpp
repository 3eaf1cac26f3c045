// The parameter groups a client reads and writes (GetParams / SetParams),
// each declared once: its struct, and describe(), which lists its fields in
// wire order with name, unit, type, allowed range and whether the field is
// limit-critical. The field check (params/field_check.hpp), the wire codec
// (params/wire_codec.hpp), the device's limit-critical policy, the host's
// JSON and JSON Schema and the tables of docs/protocol.md are all derived
// from these declarations (params/field.hpp says how).
//
// Ranges here are the ones that hold whatever else is set. What depends on
// the board (the loop rate, the hard limits, capacities) or on other fields
// (ascending thresholds, u_min < u_max) is checked by the blocks themselves
// when the set is staged, and their errors name the field the same way.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <type_traits>

#include "piezoloop/biquad.hpp"
#include "piezoloop/dahl.hpp"
#include "piezoloop/limits.hpp"
#include "piezoloop/params/field.hpp"
#include "piezoloop/pi_model.hpp"
#include "piezoloop/pid.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/recorder.hpp"
#include "piezoloop/repetitive.hpp"
#include "piezoloop/trajectory.hpp"

namespace piezoloop::params {

enum class ParamGroup : uint8_t {
    kFeedforward = 1,  // kind, PI model, Dahl
    kFeedback = 2,     // kind, SOS sections, PID
    kRepetitive = 3,   // RC on/off and its configuration
    kLimits = 4,       // runtime output limits (within the hard limits)
    kTrajectory = 5,   // wave generator
    kRecorder = 6,     // recorder configuration
    kLink = 7,         // what the board does when its client goes silent
    kInputMatrix = 8,  // sensor readings -> axis positions (multi-axis boards)
    kOutputMatrix = 9, // axis commands -> actuator channels (static decoupling)
};
inline constexpr int kGroupCount = 9;

// Groups of the whole board rather than of one axis: a request names axis 0
// for them (link/messages.hpp).
constexpr bool board_group(ParamGroup g) {
    return g == ParamGroup::kRecorder || g == ParamGroup::kLink || g == ParamGroup::kInputMatrix ||
           g == ParamGroup::kOutputMatrix;
}

constexpr const char* group_name(ParamGroup g) {
    switch (g) {
        case ParamGroup::kFeedforward: return "feedforward";
        case ParamGroup::kFeedback: return "feedback";
        case ParamGroup::kRepetitive: return "rc";
        case ParamGroup::kLimits: return "limits";
        case ParamGroup::kTrajectory: return "trajectory";
        case ParamGroup::kRecorder: return "recorder";
        case ParamGroup::kLink: return "link";
        case ParamGroup::kInputMatrix: return "input_matrix";
        case ParamGroup::kOutputMatrix: return "output_matrix";
    }
    return "?";
}

inline constexpr std::size_t kMaxWaveTable = 96;   // points of a steps / table wave
inline constexpr std::size_t kMaxLogChannels = 8;  // recorder channels a layout can carry
inline constexpr std::size_t kMaxGroupAxes = 3;    // axes a matrix layout carries (kMaxAxes)

// Enum names: the value is the index.
inline constexpr const char* kFeedforwardKindNames[] = {"none", "pi_inverse", "pi_compensator", "dahl", "pi_series"};
inline constexpr const char* kFeedbackKindNames[] = {"none", "sos", "pid"};
inline constexpr const char* kWaveformNames[] = {"sine", "triangle", "raster", "square", "steps", "table"};
inline constexpr const char* kRecordModeNames[] = {"single_shot", "continuous"};
inline constexpr const char* kTriggerModeNames[] = {"immediate", "rising", "falling"};
inline constexpr const char* kSignalNames[] = {"r", "y", "e", "u", "u_ff", "u_fb", "u_rc", "d"};
// A recorder channel's signal: one of an axis's signals, or "sync", the scan's
// sync word (scan_config.hpp: frame, line and pixel bits), which is the
// board's (a board of axes; its channel's axis is 0).
inline constexpr const char* kChannelNames[] = {"r", "y", "e", "u", "u_ff", "u_fb", "u_rc", "d", "sync"};
inline constexpr uint8_t kSyncChannel = 8;
inline constexpr const char* kClientLossNames[] = {"hold", "disarm"};
static_assert(std::size(kSignalNames) == kSignalCount);
static_assert(std::size(kChannelNames) == kSignalCount + 1 && kSyncChannel == kSignalCount);
static_assert(std::size(kWaveformNames) == static_cast<std::size_t>(Waveform::kTable) + 1);
static_assert(std::size(kFeedforwardKindNames) == static_cast<std::size_t>(FeedforwardKind::kPiSeries) + 1);

// Lets one describe() serve a group and a const group (visitors that only
// read, such as the wire writer, visit a const one).
template <class G, class Group>
concept GroupRef = std::is_same_v<std::remove_const_t<G>, Group>;

// ---- the groups -----------------------------------------------------------

struct FeedforwardParams {
    static constexpr ParamGroup kGroup = ParamGroup::kFeedforward;
    FeedforwardKind kind = FeedforwardKind::kNone;
    PiModel pi{};
    DahlParams dahl{};
    // Reference pre-filter sections on r, 0: none. Changed only while
    // disarmed: the count is limit-critical, and the pipeline refuses new
    // coefficients while armed (Pipeline::stage).
    int prefilter_count = 0;
    std::array<SosSection, kMaxPrefilterSections> prefilter{};
    bool operator==(const FeedforwardParams&) const = default;
};

struct FeedbackParams {
    static constexpr ParamGroup kGroup = ParamGroup::kFeedback;
    FeedbackKind kind = FeedbackKind::kNone;
    int sos_count = 0;
    std::array<SosSection, kMaxControllerSections> sos{};
    PidConfig pid{};
    bool operator==(const FeedbackParams&) const = default;
};

struct RepetitiveParams {
    static constexpr ParamGroup kGroup = ParamGroup::kRepetitive;
    bool enabled = false;
    RepetitiveConfig rc{};
    bool operator==(const RepetitiveParams&) const = default;
};

struct LimitsParams {
    static constexpr ParamGroup kGroup = ParamGroup::kLimits;
    LimitsConfig limits{};
    bool operator==(const LimitsParams& o) const {
        return limits.u_min_V == o.limits.u_min_V && limits.u_max_V == o.limits.u_max_V &&
               limits.slew_V_per_s == o.limits.slew_V_per_s && limits.saturation_trip_s == o.limits.saturation_trip_s;
    }
};

// The wave generator's settings; its sample rate is the device's loop rate.
struct TrajectoryParams {
    static constexpr ParamGroup kGroup = ParamGroup::kTrajectory;
    Waveform waveform = Waveform::kSine;
    float amplitude_um = 0.0f;
    float offset_um = 0.0f;
    float frequency_Hz = 1.0f;
    uint32_t cycles = 0;
    float start_phase_cycles = 0.0f;
    float return_fraction = 0.1f;
    float duty = 0.5f;
    uint16_t table_count = 0;
    std::array<float, kMaxWaveTable> table{};
    bool operator==(const TrajectoryParams&) const = default;
};

struct RecorderParams {
    static constexpr ParamGroup kGroup = ParamGroup::kRecorder;
    uint8_t channel_count = 0;
    std::array<uint8_t, kMaxLogChannels> channels{};  // SignalId values or kSyncChannel, first channel_count used
    uint32_t decimation = 1;
    RecordMode mode = RecordMode::kContinuous;
    TriggerMode trigger = TriggerMode::kImmediate;
    uint8_t trigger_signal = 0;
    float trigger_level = 0.0f;  // physical units of the trigger signal (µm or V)
    uint32_t pre_trigger = 0;
    uint32_t length = 0;
    // The axis of each channel and of the trigger signal: a channel is an
    // (axis, signal) pair. Last in the struct, second in the layout.
    std::array<uint8_t, kMaxLogChannels> axes{};
    uint8_t trigger_axis = 0;
    bool operator==(const RecorderParams&) const = default;
};

// What the board does when the client that started a setpoint stream or a
// wave goes silent (link/device.hpp, "client loss").
enum class ClientLossAction : uint8_t {
    kHold = 0,    // stop the stream or wave: the setpoint holds, the loop stays armed
    kDisarm = 1,  // the same, and disarm the loop
};

struct LinkParams {
    static constexpr ParamGroup kGroup = ParamGroup::kLink;
    float client_timeout_s = 1.0f;  // 0: never
    ClientLossAction on_client_loss = ClientLossAction::kHold;
    bool operator==(const LinkParams&) const = default;
};

// The matrices of a multi-axis board (axes/axis_matrix.hpp), as 3 x 3
// row-major layouts whatever the board's axis count: the top-left
// axis_count x axis_count block is the matrix, every other element must be
// the identity's (1 on the diagonal, 0 elsewhere, offsets 0).
struct InputMatrixParams {
    static constexpr ParamGroup kGroup = ParamGroup::kInputMatrix;
    uint8_t axis_count = 1;
    std::array<float, kMaxGroupAxes * kMaxGroupAxes> gain{1, 0, 0, 0, 1, 0, 0, 0, 1};
    std::array<float, kMaxGroupAxes> offset_um{};
    bool operator==(const InputMatrixParams&) const = default;
};

struct OutputMatrixParams {
    static constexpr ParamGroup kGroup = ParamGroup::kOutputMatrix;
    uint8_t axis_count = 1;
    std::array<float, kMaxGroupAxes * kMaxGroupAxes> gain{1, 0, 0, 0, 1, 0, 0, 0, 1};
    bool operator==(const OutputMatrixParams&) const = default;
};

// ---- the declarations ---------------------------------------------------------

// One controller section, discrete at the loop rate, a0 = 1.
template <class V, GroupRef<SosSection> S>
constexpr void describe(V& v, S& s) {
    v.value(f64("b0", "1", "numerator, z^0"), s.b0);
    v.value(f64("b1", "1", "numerator, z^-1"), s.b1);
    v.value(f64("b2", "1", "numerator, z^-2"), s.b2);
    v.value(f64("a1", "1", "denominator, z^-1 (a0 = 1)"), s.a1);
    v.value(f64("a2", "1", "denominator, z^-2"), s.a2);
}

template <class V, GroupRef<FeedforwardParams> G>
constexpr void describe(V& v, G& g) {
    v.value(enumeration("kind", kFeedforwardKindNames,
                        "pi_inverse: `pi` is the stage model (V -> um) and its analytic inverse runs; "
                        "pi_compensator: `pi` is the compensator (um -> V); dahl: inversion-free Dahl feedforward; "
                        "pi_series: the compensator in series after the feedback, u = limits(pi(r + u_fb))")
                .limit_critical(),
            g.kind);
    v.begin("pi");
    v.value(f32("input_gain", "1", "f = input_gain * x + input_offset; non-zero"), g.pi.input_gain);
    v.value(f32("input_offset", "1", "input offset, units of f"), g.pi.input_offset);
    v.value(f32("p0", "1", "weight of the linear (threshold-0) term"), g.pi.p0);
    v.count(u8("count", "play operators").range(0, kMaxPlayOperators), g.pi.count);
    v.values(f32("thresholds", "1", "play thresholds, units of f: strictly ascending").range(0, kFloatMax), g.pi.thresholds,
             g.pi.count, Travel::kCount);
    v.values(f32("weights", "1", "play weights"), g.pi.weights, g.pi.count, Travel::kCount);
    v.count(u8("dead_zones", "input map g(x) = x + sum_i q_i max(x - d_i, 0) before the affine input (Kuhnen's "
                             "modified PI compensator), 0..8; 0: g(x) = x").range(0, kMaxDeadZones),
            g.pi.dead_zones);
    v.values(f32("dead_zone_thresholds", "1", "d_i, units of x: strictly ascending"), g.pi.dead_zone_thresholds,
             g.pi.dead_zones, Travel::kCount);
    v.values(f32("dead_zone_weights", "1", "q_i: 1 + q_1 + ... + q_i > 0 (g increasing)"), g.pi.dead_zone_weights,
             g.pi.dead_zones, Travel::kCount);
    v.end();
    v.begin("dahl");
    // Checked by the Dahl block when the kind is dahl (the other kinds leave them 0).
    v.value(f32("alpha1", "1", "path damping (1/x), [0, 1e15]"), g.dahl.alpha1);
    v.value(f32("alpha2", "1", "path stiffness (1/x^2), [1e-30, 1e30]"), g.dahl.alpha2);
    v.value(f32("beta1", "1", "output weight on z2"), g.dahl.beta1);
    v.value(f32("beta2", "1", "output weight on z1"), g.dahl.beta2);
    v.value(f32("gamma_a", "1", "input gain B_H"), g.dahl.gamma_a);
    v.value(f32("ga", "um/V", "actuator gain, [1e-30, 1e30]"), g.dahl.ga);
    v.end();
    v.count(u8("prefilter_count", "reference pre-filter sections on r (um -> um), 0..2; 0: none")
                .range(0, kMaxPrefilterSections)
                .limit_critical(),
            g.prefilter_count);
    v.objects("prefilter", g.prefilter, g.prefilter_count, Travel::kAll);
}

template <class V, GroupRef<FeedbackParams> G>
constexpr void describe(V& v, G& g) {
    v.value(enumeration("kind", kFeedbackKindNames, "feedback of e = r - y").limit_critical(), g.kind);
    v.count(u8("sos_count", "sections in use, 1..4 with kind sos").range(0, kMaxControllerSections).limit_critical(),
            g.sos_count);
    v.objects("sections", g.sos, g.sos_count, Travel::kAll);
    v.begin("pid");
    v.value(f32("kp", "V/um", "proportional gain").range(0, kFloatMax), g.pid.kp);
    v.value(f32("ki_per_s", "V/(um*s)", "integral gain").range(0, kFloatMax), g.pid.ki_per_s);
    v.value(f32("kd_s", "V*s/um", "derivative gain").range(0, kFloatMax), g.pid.kd_s);
    v.value(f32("derivative_cutoff_Hz", "Hz", "derivative low-pass, (0, rate / 2)"), g.pid.derivative_cutoff_Hz);
    v.value(f32("u_min", "V", "PID output minimum (um with pi_series)").limit_critical(), g.pid.u_min);
    v.value(f32("u_max", "V", "PID output maximum (um with pi_series)").limit_critical(), g.pid.u_max);
    v.end();
}

template <class V, GroupRef<RepetitiveParams> G>
constexpr void describe(V& v, G& g) {
    v.value(boolean("enabled", "plug-in repetitive control on (needs a feedback)").limit_critical(), g.enabled);
    v.value(i32("period_samples", "samples", "N: the reference period, 2..rc_capacity (hello)"), g.rc.period_samples);
    v.value(i32("m1", "samples", "lead compensating Q's phase lag, >= 0"), g.rc.m1);
    v.value(i32("m2", "samples", "lead compensating the loop's phase lag, >= 0, N - m1 - m2 >= 1"), g.rc.m2);
    v.value(f32("k_rc", "1", "RC gain, (0, 2)"), g.rc.k_rc);
    v.begin("q");
    describe(v, g.rc.q);
    v.end();
}

template <class V, GroupRef<LimitsParams> G>
constexpr void describe(V& v, G& g) {
    v.value(f32("u_min_V", "V", "output minimum, within the hard limits (hello)").range(-1e6, 1e6).limit_critical(),
            g.limits.u_min_V);
    v.value(f32("u_max_V", "V", "output maximum, within the hard limits, > u_min_V").range(-1e6, 1e6).limit_critical(),
            g.limits.u_max_V);
    v.value(f32("slew_V_per_s", "V/s", "slew limit, up to the hard slew limit").range(0, 1e12).open_min().limit_critical(),
            g.limits.slew_V_per_s);
    v.value(f32("saturation_trip_s", "s", "trip after this long at a limit; 0 disables").range(0, 1000).limit_critical(),
            g.limits.saturation_trip_s);
}

template <class V, GroupRef<TrajectoryParams> G>
constexpr void describe(V& v, G& g) {
    v.value(enumeration("waveform", kWaveformNames, "r = offset + amplitude * w(phase)"), g.waveform);
    v.value(f32("amplitude_um", "um", "peak (half of peak-to-peak)").range(0, 1e6), g.amplitude_um);
    v.value(f32("offset_um", "um", "offset").range(-1e6, 1e6), g.offset_um);
    v.value(f32("frequency_Hz", "Hz", "wave frequency, (0, rate / 2)").range(0, kFloatMax).open_min(), g.frequency_Hz);
    v.value(u32("cycles", "1", "periods to run, 0 = forever"), g.cycles);
    v.value(f32("start_phase_cycles", "1", "start phase").range(0, 1).open_max(), g.start_phase_cycles);
    v.value(f32("return_fraction", "1", "raster: fly-back share of the period, [2^-16, 1 - 2^-16]"), g.return_fraction);
    v.value(f32("duty", "1", "square: duty, [2^-16, 1 - 2^-16]"), g.duty);
    v.count(u16("table_count", "points of a steps / table wave").range(0, kMaxWaveTable), g.table_count);
    v.values(f32("table", "1", "steps / table: normalised values in [-1, 1]"), g.table, g.table_count, Travel::kCount);
}

template <class V, GroupRef<RecorderParams> G>
constexpr void describe(V& v, G& g) {
    v.count(u8("channel_count", "recorded channels: the device's recorder channel count (hello)").range(0, kMaxLogChannels),
            g.channel_count);
    v.values(enumeration("channels", kChannelNames, "signal of each channel, in frame order (sync: a board of axes)"),
             g.channels, g.channel_count,
             Travel::kAll);
    v.values(u8("axes", "axis of each channel, 0..axis_count-1 (hello)").range(0, kMaxGroupAxes - 1), g.axes,
             g.channel_count, Travel::kAll);
    v.value(u32("decimation", "ticks", "keep every N-th tick").range(1, 4294967295.0), g.decimation);
    v.value(enumeration("mode", kRecordModeNames, "single_shot stops after `length` frames"), g.mode);
    v.value(enumeration("trigger", kTriggerModeNames, "start condition"), g.trigger);
    v.value(enumeration("trigger_signal", kSignalNames, "signal the trigger watches"), g.trigger_signal);
    v.value(u8("trigger_axis", "axis of the trigger signal, 0..axis_count-1").range(0, kMaxGroupAxes - 1),
            g.trigger_axis);
    v.value(f32("trigger_level", "um or V", "level, in the trigger signal's unit"), g.trigger_level);
    v.value(u32("pre_trigger", "frames", "frames kept from before the trigger"), g.pre_trigger);
    v.value(u32("length", "frames", "frames of a single-shot record"), g.length);
}

template <class V, GroupRef<LinkParams> G>
constexpr void describe(V& v, G& g) {
    v.value(f32("client_timeout_s", "s",
                "silence (no valid frame) after which a setpoint stream, a wave or an excitation the client started "
                "is stopped; 0: never; above 0 at least one tick")
                .range(0, 3600),
            g.client_timeout_s);
    v.value(enumeration("on_client_loss", kClientLossNames,
                        "hold: the setpoint holds, the loop stays armed; disarm: the loop is disarmed too"),
            g.on_client_loss);
}

// Every element of the matrices travels (and is shown in JSON): the arrays'
// element counts are constants, not fields.
template <class V, GroupRef<InputMatrixParams> G>
constexpr void describe(V& v, G& g) {
    std::size_t gains = kMaxGroupAxes * kMaxGroupAxes, offsets = kMaxGroupAxes;
    v.value(u8("axis_count", "the board's axis count (hello)").range(1, kMaxGroupAxes).limit_critical(), g.axis_count);
    v.values(f32("gain", "1",
                 "y_axis = gain * reading + offset_um; row-major 3x3, |element| <= 16, condition number <= 1000")
                 .limit_critical(),
             g.gain, gains, Travel::kAll);
    v.values(f32("offset_um", "um", "axis offsets, |offset| <= 1000 um").limit_critical(), g.offset_um, offsets,
             Travel::kAll);
}

template <class V, GroupRef<OutputMatrixParams> G>
constexpr void describe(V& v, G& g) {
    std::size_t gains = kMaxGroupAxes * kMaxGroupAxes;
    v.value(u8("axis_count", "the board's axis count (hello)").range(1, kMaxGroupAxes).limit_critical(), g.axis_count);
    v.values(f32("gain", "1",
                 "u_channel = gain * u_axis, then the channel limits; row-major 3x3, |element| <= 16, condition "
                 "number <= 1000")
                 .limit_critical(),
             g.gain, gains, Travel::kAll);
}

// ---- dispatch by group id ------------------------------------------------------

template <class G>
struct GroupTag {
    using type = G;
};

// Calls f(GroupTag<G>{}) with the group whose id is g; false for an unknown id.
// The one list of groups: the device, the host's get / set and the schema use it.
template <class F>
constexpr bool with_group(ParamGroup g, F&& f) {
    switch (g) {
        case ParamGroup::kFeedforward: f(GroupTag<FeedforwardParams>{}); return true;
        case ParamGroup::kFeedback: f(GroupTag<FeedbackParams>{}); return true;
        case ParamGroup::kRepetitive: f(GroupTag<RepetitiveParams>{}); return true;
        case ParamGroup::kLimits: f(GroupTag<LimitsParams>{}); return true;
        case ParamGroup::kTrajectory: f(GroupTag<TrajectoryParams>{}); return true;
        case ParamGroup::kRecorder: f(GroupTag<RecorderParams>{}); return true;
        case ParamGroup::kLink: f(GroupTag<LinkParams>{}); return true;
        case ParamGroup::kInputMatrix: f(GroupTag<InputMatrixParams>{}); return true;
        case ParamGroup::kOutputMatrix: f(GroupTag<OutputMatrixParams>{}); return true;
    }
    return false;
}

// ---- groups of a pipeline parameter set ----------------------------------------

constexpr FeedforwardParams feedforward_of(const PipelineParams& p) {
    return {p.feedforward, p.pi, p.dahl, p.prefilter_count, p.prefilter};
}
constexpr FeedbackParams feedback_of(const PipelineParams& p) { return {p.feedback, p.sos_count, p.sos, p.pid}; }
constexpr RepetitiveParams rc_of(const PipelineParams& p) { return {p.rc_enabled, p.rc}; }
constexpr LimitsParams limits_of(const PipelineParams& p) { return {p.limits}; }

constexpr void set_group(PipelineParams& p, const FeedforwardParams& g) {
    p.feedforward = g.kind;
    p.pi = g.pi;
    p.dahl = g.dahl;
    p.prefilter_count = g.prefilter_count;
    p.prefilter = g.prefilter;
}
constexpr void set_group(PipelineParams& p, const FeedbackParams& g) {
    p.feedback = g.kind;
    p.sos_count = g.sos_count;
    p.sos = g.sos;
    p.pid = g.pid;
}
constexpr void set_group(PipelineParams& p, const RepetitiveParams& g) {
    p.rc_enabled = g.enabled;
    p.rc = g.rc;
}
constexpr void set_group(PipelineParams& p, const LimitsParams& g) { p.limits = g.limits; }

// The wave generator's configuration of a trajectory group at a loop rate.
// The table points into `v`, which must outlive the returned value.
constexpr TrajectoryConfig trajectory_config(const TrajectoryParams& v, float rate_Hz) {
    TrajectoryConfig c;
    c.waveform = v.waveform;
    c.amplitude_um = v.amplitude_um;
    c.offset_um = v.offset_um;
    c.frequency_Hz = v.frequency_Hz;
    c.sample_rate_Hz = rate_Hz;
    c.cycles = v.cycles;
    c.start_phase_cycles = v.start_phase_cycles;
    c.return_fraction = v.return_fraction;
    c.duty = v.duty;
    c.table = std::span<const float>(v.table.data(), v.table_count <= kMaxWaveTable ? v.table_count : 0);
    return c;
}

}  // namespace piezoloop::params
