// Message layouts of the link protocol (docs/protocol.md has them as tables).
//
// Every message is a struct with its type id (kType), write(Writer&) and
// read(Reader&) that follow its layout, little-endian, with no padding and no
// optional fields: the layout of a type is fixed for a protocol version
// (variable-length arrays travel with their count and only that many
// elements). Requests come from the host, replies echo the request's sequence
// id, log blocks are sent by the device unasked.
//
// The messages with more than one field declare their layout as the
// parameter groups do (params/field.hpp): describe(visitor, message) lists
// the fields in wire order with name, wire type and meaning. Their codec is
// the groups' (params/wire_codec.hpp), and docs/protocol.md's layout tables
// are generated from the same declarations (`piezoloop schema --layout`), so
// the document, the encoder and the decoder cannot disagree.
//
// The codec checks form only (lengths, booleans, counts within their arrays).
// Values go to the core's validation unchanged, so a NaN or an out-of-range
// parameter comes back as an error reply naming the field the core names.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "piezoloop/biquad.hpp"
#include "piezoloop/dahl.hpp"
#include "piezoloop/limits.hpp"
#include "piezoloop/link/framing.hpp"
#include "piezoloop/link/wire.hpp"
#include "piezoloop/params/field.hpp"
#include "piezoloop/params/groups.hpp"
#include "piezoloop/params/wire_codec.hpp"
#include "piezoloop/pi_model.hpp"
#include "piezoloop/pid.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/recorder.hpp"
#include "piezoloop/repetitive.hpp"
#include "piezoloop/scan/scan_config.hpp"
#include "piezoloop/trajectory.hpp"

namespace piezoloop::link {

// Version 1. A device answers Hello in any version (with its own version in
// the reply) and refuses every other message whose header version differs.
// Version 2: HelloReply's serial grew from 24 to 32 bytes (the STM32's
// 24-hex-digit unique ID plus the terminating zero did not fit).
// Version 3: StartExcitation / StopExcitation, Save / Load / Forget;
// HelloReply ends with the excitation capacity, StatusReply with the
// excitation's state and the storage block.
// Version 4: the feedforward group ends with the reference pre-filter
// (prefilter_count and up to two sections).
// Version 5: axes. HelloReply ends with the axis count and each axis's hard
// limits and full scales, StatusReply with each axis's state and each
// channel's clamps; the axis-scoped requests carry axis:u8; the recorder's
// channels are (axis, signal) pairs; the input_matrix and output_matrix
// groups; StartWave's body is always axis and flags.
// Version 6: scans. StartScan; the recorder's channel "sync" (the scan's
// sync word); StatusReply ends with the scan's state.
// Version 7: the feedforward group's `pi` ends with the input map's dead
// zones (dead_zones and up to eight thresholds and weights).
inline constexpr uint8_t kProtocolVersion = 7;

enum class MsgType : uint8_t {
    // Requests, host -> device.
    kHello = 0x01,
    kGetStatus = 0x02,
    kGetParams = 0x03,
    kSetParams = 0x04,
    kArm = 0x05,
    kDisarm = 0x06,
    kClearTrip = 0x07,
    kStartWave = 0x08,
    kStopWave = 0x09,
    kStreamStart = 0x0A,
    kSetpoints = 0x0B,
    kStreamStop = 0x0C,
    kRecorderArm = 0x0D,
    kRecorderStop = 0x0E,
    kStartExcitation = 0x0F,
    kStopExcitation = 0x10,
    kSave = 0x11,    // store the current parameter set in the board's storage
    kLoad = 0x12,    // validate and apply the stored set
    kForget = 0x13,  // erase the board's storage
    kStartScan = 0x14,  // run a scan on the axes of a board of two or three
    // Replies, device -> host, with the request's sequence id.
    kAck = 0x80,
    kHelloReply = 0x81,
    kStatusReply = 0x82,
    kParamsReply = 0x83,
    kSetpointAck = 0x84,
    kError = 0xFF,
    // Device -> host, unasked.
    kLogBlock = 0xC0,
};

constexpr bool is_request(uint8_t t) { return (t >= 0x01 && t <= 0x14); }

// Every message type with its body and replies, as docs/protocol.md's
// table of message types states them (generated from this list by
// `piezoloop schema --messages`; a host test checks the committed table and
// that every request type is listed).
struct MessageTypeDoc {
    MsgType type;
    const char* name;
    const char* body;
    const char* reply;  // "" for replies and unasked messages
};
inline constexpr std::array<MessageTypeDoc, 27> kMessageTypes = {{
    {MsgType::kHello, "Hello", "empty", "HelloReply"},
    {MsgType::kGetStatus, "GetStatus", "empty", "StatusReply"},
    {MsgType::kGetParams, "GetParams", "group:u8, axis:u8", "ParamsReply"},
    {MsgType::kSetParams, "SetParams", "group:u8, axis:u8 + group layout", "Ack / Error"},
    {MsgType::kArm, "Arm", "empty", "Ack / Error(tripped)"},
    {MsgType::kDisarm, "Disarm", "empty", "Ack"},
    {MsgType::kClearTrip, "ClearTrip", "empty", "Ack / Error(armed, tripped)"},
    {MsgType::kStartWave, "StartWave", "axis:u8, flags:u8 (runs the axis's trajectory group; see below)",
     "Ack / Error"},
    {MsgType::kStopWave, "StopWave", "axis:u8", "Ack / Error(invalid_param)"},
    {MsgType::kStreamStart, "StreamStart", "axis:u8, prefill:u16", "SetpointAck"},
    {MsgType::kSetpoints, "Setpoints", "SetpointBlock", "SetpointAck / Error"},
    {MsgType::kStreamStop, "StreamStop", "drain:bool", "Ack"},
    {MsgType::kRecorderArm, "RecorderArm", "empty", "Ack / Error(not_configured)"},
    {MsgType::kRecorderStop, "RecorderStop", "empty", "Ack"},
    {MsgType::kStartExcitation, "StartExcitation", "see below", "Ack / Error"},
    {MsgType::kStopExcitation, "StopExcitation", "axis:u8", "Ack / Error(invalid_param)"},
    {MsgType::kSave, "Save", "empty", "Ack / Error(unsupported, armed, invalid_param, storage)"},
    {MsgType::kLoad, "Load", "empty",
     "Ack / Error(unsupported, armed, not_configured, storage, invalid_param, busy)"},
    {MsgType::kForget, "Forget", "empty", "Ack / Error(unsupported, armed, storage)"},
    {MsgType::kStartScan, "StartScan", "see below", "Ack / Error"},
    {MsgType::kAck, "Ack", "request_type:u8", ""},
    {MsgType::kHelloReply, "HelloReply", "see below", ""},
    {MsgType::kStatusReply, "StatusReply", "see below", ""},
    {MsgType::kParamsReply, "ParamsReply", "group:u8, axis:u8 + group layout", ""},
    {MsgType::kSetpointAck, "SetpointAck", "see below", ""},
    {MsgType::kLogBlock, "LogBlock", "see below", ""},
    {MsgType::kError, "Error", "see below", ""},
}};

enum class ErrorCode : uint8_t {
    kNone = 0,
    kUnknownType = 1,    // message type not handled by the receiver
    kBadVersion = 2,     // header version differs from the device's
    kMalformed = 3,      // body length or form does not match the layout
    kInvalidParam = 4,   // rejected by validation: group/field/index/message say why
    kArmed = 5,          // limit-critical change, or clear-trip, while armed
    kBusy = 6,           // previous parameter set not yet swapped in, wave or stream running
    kSequence = 7,       // setpoint block out of sequence (dropped)
    kNoSpace = 8,        // setpoint block does not fit the FIFO (dropped)
    kNotConfigured = 9,  // recorder arm before a recorder configuration
    kUnsupported = 10,   // feature absent on this device (see capabilities)
    kTripped = 11,       // arm refused: the limiter is tripped (clear it first)
    kBadGroup = 12,      // unknown parameter group
    kStorage = 13,       // storage failed, or holds no usable set: field/message say why
};

constexpr const char* error_code_name(ErrorCode c) {
    switch (c) {
        case ErrorCode::kNone: return "none";
        case ErrorCode::kUnknownType: return "unknown_type";
        case ErrorCode::kBadVersion: return "bad_version";
        case ErrorCode::kMalformed: return "malformed";
        case ErrorCode::kInvalidParam: return "invalid_param";
        case ErrorCode::kArmed: return "armed";
        case ErrorCode::kBusy: return "busy";
        case ErrorCode::kSequence: return "sequence";
        case ErrorCode::kNoSpace: return "no_space";
        case ErrorCode::kNotConfigured: return "not_configured";
        case ErrorCode::kUnsupported: return "unsupported";
        case ErrorCode::kTripped: return "tripped";
        case ErrorCode::kBadGroup: return "bad_group";
        case ErrorCode::kStorage: return "storage";
    }
    return "?";
}

// Capability bits of the hello reply.
namespace cap {
inline constexpr uint32_t kFloat = 1u << 0;           // float pipeline (samples in physical units)
inline constexpr uint32_t kQ31 = 1u << 1;             // Q31 pipeline
inline constexpr uint32_t kDahl = 1u << 2;            // Dahl feedforward available
inline constexpr uint32_t kRepetitive = 1u << 3;
inline constexpr uint32_t kSetpointStream = 1u << 4;
inline constexpr uint32_t kRecorder = 1u << 5;
inline constexpr uint32_t kWaveTable = 1u << 6;       // kSteps / kTable waveforms
inline constexpr uint32_t kExcitation = 1u << 7;      // StartExcitation / StopExcitation, signal d
inline constexpr uint32_t kStorage = 1u << 8;         // Save / Load / Forget: the board keeps a parameter set
inline constexpr uint32_t kAxisMatrices = 1u << 9;    // input_matrix / output_matrix groups take any valid matrix
inline constexpr uint32_t kScan = 1u << 10;           // StartScan, the recorder's sync channel (two or three axes)
}  // namespace cap

enum class SampleFormat : uint8_t { kFloat32 = 0, kQ31 = 1 };

inline constexpr std::size_t kNameSize = 16;          // board, firmware version
inline constexpr std::size_t kSerialSize = 32;         // up to 31 characters
inline constexpr std::size_t kGroupTextSize = 16;     // error reply texts
inline constexpr std::size_t kFieldTextSize = 32;
inline constexpr std::size_t kMessageTextSize = 96;
inline constexpr std::size_t kMaxSetpointsPerBlock = 120;
inline constexpr std::size_t kMaxLinkAxes = params::kMaxGroupAxes;  // axes a layout carries
inline constexpr std::size_t kLogBlockHeader = 28;    // body bytes before the samples
// Samples per log block: 480 bytes of samples whatever the channel count.
constexpr std::size_t log_frames_per_block(std::size_t channels) {
    return channels == 0 ? 0 : ((kMaxBody - kLogBlockHeader) / (4 * channels) > 255
                                    ? 255
                                    : (kMaxBody - kLogBlockHeader) / (4 * channels));
}

// ---- parameter groups ------------------------------------------------------
// Declared once, with their layouts, in params/groups.hpp.

using params::board_group;
using params::FeedbackParams;
using params::FeedforwardParams;
using params::group_name;
using params::InputMatrixParams;
using params::OutputMatrixParams;
using params::kMaxLogChannels;
using params::kMaxWaveTable;
using params::LimitsParams;
using params::LinkParams;
using params::ParamGroup;
using params::RecorderParams;
using params::RepetitiveParams;
using params::TrajectoryParams;

// ---- messages -----------------------------------------------------------------

// Requests with no body.
template <MsgType Type>
struct EmptyMessage {
    static constexpr MsgType kType = Type;
    bool operator==(const EmptyMessage&) const = default;
    void write(Writer&) const {}
    void read(Reader&) {}
};
using Hello = EmptyMessage<MsgType::kHello>;
using Save = EmptyMessage<MsgType::kSave>;
using Load = EmptyMessage<MsgType::kLoad>;
using Forget = EmptyMessage<MsgType::kForget>;
using GetStatus = EmptyMessage<MsgType::kGetStatus>;
using Arm = EmptyMessage<MsgType::kArm>;
using Disarm = EmptyMessage<MsgType::kDisarm>;
using ClearTrip = EmptyMessage<MsgType::kClearTrip>;
using RecorderArm = EmptyMessage<MsgType::kRecorderArm>;
using RecorderStop = EmptyMessage<MsgType::kRecorderStop>;

// Requests whose body is the axis they act on (0 .. axis_count - 1, hello).
template <MsgType Type>
struct AxisMessage {
    static constexpr MsgType kType = Type;
    uint8_t axis = 0;
    bool operator==(const AxisMessage&) const = default;
    void write(Writer& w) const { w.u8(axis); }
    void read(Reader& r) { axis = r.u8(); }
};
using StopWave = AxisMessage<MsgType::kStopWave>;
using StopExcitation = AxisMessage<MsgType::kStopExcitation>;

// Runs the trajectory group's wave of one axis. The flags make the wave's
// first sample, the arm of every axis, the recorder's arm and a restart of
// the emulated stage happen at the same tick boundary, so the first recorded
// frame is the wave's tick 0 with the loop freshly armed and the stage at
// rest (how `piezoloop sim` starts).
struct StartWave {
    static constexpr MsgType kType = MsgType::kStartWave;
    static constexpr uint8_t kArmLoop = 1u << 0;       // arm the loop (refused if already armed)
    static constexpr uint8_t kArmRecorder = 1u << 1;   // arm the recorder (configured first)
    static constexpr uint8_t kRestartStage = 1u << 2;  // emulated stage back at rest (DeviceHooks::restart_stage)
    static constexpr uint8_t kDetached = 1u << 3;      // the wave runs on when the client goes silent
    static constexpr uint8_t kKnownFlags = kArmLoop | kArmRecorder | kRestartStage | kDetached;
    // kEveryAxis: every axis's wave at the same tick (a board of axes: the
    // waves of X, Y and Z share one clock from their first sample).
    static constexpr uint8_t kEveryAxis = 0xFF;
    uint8_t flags = 0;
    uint8_t axis = 0;  // first on the wire
    bool operator==(const StartWave&) const = default;
    void write(Writer& w) const {
        w.u8(axis);
        w.u8(flags);
    }
    void read(Reader& r) {
        axis = r.u8();
        flags = r.u8();
    }
};

// Starts an excitation (excitation.hpp) at the next tick: a signal d added
// at the command or the reference, for measurements (`piezoloop measure`).
// The flags work as StartWave's: the excitation's first sample, the loop's
// arm, the recorder's arm and the emulated stage's restart happen at one
// tick boundary, so the first recorded frame is the excitation's sample 0.
// The sample rate is the device's loop rate.
struct StartExcitation;
template <class V, params::GroupRef<StartExcitation> M>
constexpr void describe(V& v, M& m) {
    using namespace params;
    auto& c = m.config;
    v.value(u8("axis", "the axis excited, 0..axis_count-1 (hello)"), m.axis);
    v.value(u8("flags", "StartWave's bits (arm loop, arm recorder, restart stage, detached)"), m.flags);
    v.value(u8("signal", "0 multisine, 1 log sweep, 2 PRBS, 3 step, 4 triangle, 5 raised cosine"), c.signal);
    v.value(u8("point", "0 command (V), 1 reference (um); other values malformed"), c.point);
    v.value(f32("amplitude", "V or um", "within +-1e6 (negative inverts the shape)"), c.amplitude);
    v.value(f32("offset", "V or um", "added throughout (an open loop's bias)"), c.offset);
    v.value(u32("period_samples", "samples",
                "multisine N (<= excitation_capacity), sweep length, step/triangle/raised-cosine period"),
            c.period_samples);
    v.value(u32("first_bin", "1", "multisine: first line k1 >= 1"), c.first_bin);
    v.value(u32("last_bin", "1", "multisine: last line k2, k1 <= k2 < N/2"), c.last_bin);
    v.value(f32("f1_Hz", "Hz", "sweep: start, 0 < f1 < f2"), c.f1_Hz);
    v.value(f32("f2_Hz", "Hz", "sweep: end, f2 < rate/2"), c.f2_Hz);
    v.value(u8("prbs_order", "PRBS: 2..24"), c.prbs_order);
    v.value(u32("prbs_hold", "samples", "PRBS: samples per bit, 1..65536, and (2^prbs_order - 1)*prbs_hold < 2^32"),
            c.prbs_hold);
    v.value(u32("periods", "1", "then d returns to 0 and the excitation ends; 0 runs until StopExcitation"),
            c.periods);
}

struct StartExcitation {
    static constexpr MsgType kType = MsgType::kStartExcitation;
    static constexpr uint8_t kArmLoop = StartWave::kArmLoop;
    static constexpr uint8_t kArmRecorder = StartWave::kArmRecorder;
    static constexpr uint8_t kRestartStage = StartWave::kRestartStage;
    static constexpr uint8_t kDetached = StartWave::kDetached;
    static constexpr uint8_t kKnownFlags = StartWave::kKnownFlags;
    uint8_t flags = 0;
    ExcitationConfig config{};  // sample_rate_Hz is not sent
    uint8_t axis = 0;           // first on the wire
    bool operator==(const StartExcitation& o) const {
        const ExcitationConfig &a = config, &b = o.config;
        return axis == o.axis && flags == o.flags && a.signal == b.signal && a.point == b.point && a.amplitude == b.amplitude &&
               a.offset == b.offset && a.period_samples == b.period_samples && a.first_bin == b.first_bin &&
               a.last_bin == b.last_bin && a.f1_Hz == b.f1_Hz && a.f2_Hz == b.f2_Hz &&
               a.prbs_order == b.prbs_order && a.prbs_hold == b.prbs_hold && a.periods == b.periods;
    }
    void write(Writer& w) const { params::write_group(w, *this); }
    void read(Reader& r) {
        params::read_group(r, *this);
        if (config.point != ExcitationPoint::kCommand && config.point != ExcitationPoint::kReference) r.mark_bad();
    }
};

// Runs a scan (scan/scan_generator.hpp, docs/scan.md) on a board of two
// or three axes: x on axis 0, y on axis 1, z (held at hold_z_um) on axis 2.
// Each axis first moves from where the stage is (the held setpoint of a loop
// that stays armed, else its reading) to the scan's first point with the
// minimum-jerk approach, then the scan's clock runs; the recorder's "sync"
// channel carries each tick's events. The flags work as StartWave's (the
// approach's first tick, the arm, the recorder's arm and the stage's restart
// at one tick boundary). StopWave of any axis stops it where it is.
struct StartScan;
template <class V, params::GroupRef<StartScan> M>
constexpr void describe(V& v, M& m) {
    using namespace params;
    auto& c = m.config;
    v.value(u8("flags", "StartWave's bits (arm loop, arm recorder, restart stage, detached)"), m.flags);
    v.value(u8("pattern", "0 raster, 1 spiral, 2 Lissajous, 3 cycloid; other values malformed"), c.pattern);
    v.value(f32("centre_x_um", "um", "the pattern's centre"), c.centre_x_um);
    v.value(f32("centre_y_um", "um", "the pattern's centre"), c.centre_y_um);
    v.value(f32("hold_z_um", "um", "where the third axis is held"), c.hold_z_um);
    v.value(f32("rotation_deg", "deg", "the pattern turned about the centre, [-360, 360]"), c.rotation_deg);
    v.value(u32("frames", "1", "frames to scan; 0 repeats until StopWave"), c.frames);
    v.value(u32("pixels_per_line", "1", "pixel clocks a line, [1, 65536]"), c.pixels_per_line);
    v.value(f32("size_x_um", "um", "raster, cycloid: used width; Lissajous: x peak to peak"), c.size_x_um);
    v.value(f32("size_y_um", "um", "raster, cycloid: height; Lissajous: y peak to peak"), c.size_y_um);
    v.value(u32("lines_per_frame", "1", "raster, cycloid: [1, 65536]"), c.lines_per_frame);
    v.value(f32("line_rate_Hz", "Hz", "raster: lines a second"), c.line_rate_Hz);
    v.value(f32("retrace_speed_factor", "1", "raster: retrace speed / trace speed, [1, 16]"), c.retrace_speed_factor);
    v.value(f32("overscan_fraction", "1", "raster: constant-speed run beyond each end, share of the width, [0, 1]"),
            c.overscan_fraction);
    v.value(f32("turnaround_s", "s", "raster: each turnaround (>= 2 ticks)"), c.turnaround_s);
    v.value(u8("slow_axis", "raster: 0 staircase, 1 ramp; other values malformed"), c.slow_axis);
    v.value(boolean("bidirectional", "raster: both sweeps are lines"), c.bidirectional);
    v.value(u8("fast_axis", "raster: 0 triangle, 1 sine; other values malformed"), c.fast_axis);
    v.value(u8("spiral_mode", "spiral: 0 constant angular velocity, 1 constant linear velocity; other values malformed"),
            c.spiral_mode);
    v.value(f32("radius_um", "um", "spiral: outer radius; cycloid: circle radius"), c.radius_um);
    v.value(u32("turns", "1", "spiral: [1, 65536]"), c.turns);
    v.value(f32("turn_rate_Hz", "Hz", "spiral, cycloid: turns a second"), c.turn_rate_Hz);
    v.value(f32("linear_speed_um_s", "um/s", "spiral (CLV): tangential speed"), c.linear_speed_um_s);
    v.value(f32("frequency_x_Hz", "Hz", "Lissajous: x"), c.frequency_x_Hz);
    v.value(f32("frequency_y_Hz", "Hz", "Lissajous: y"), c.frequency_y_Hz);
    v.value(f32("phase_y_deg", "deg", "Lissajous: y's phase"), c.phase_y_deg);
    v.value(u32("turns_per_line", "1", "cycloid: [1, 65536]"), c.turns_per_line);
}

struct StartScan {
    static constexpr MsgType kType = MsgType::kStartScan;
    uint8_t flags = 0;
    ScanConfig config{};  // sample_rate_Hz is not sent: the board's loop rate
    // config's sample_rate_Hz compares too: not on the wire, a decoded one keeps its default.
    bool operator==(const StartScan&) const = default;
    void write(Writer& w) const { params::write_group(w, *this); }
    void read(Reader& r) {
        params::read_group(r, *this);
        const ScanConfig& c = config;
        if (static_cast<uint8_t>(c.pattern) > static_cast<uint8_t>(ScanPattern::kCycloid) ||
            static_cast<uint8_t>(c.slow_axis) > static_cast<uint8_t>(SlowAxis::kRamp) ||
            static_cast<uint8_t>(c.fast_axis) > static_cast<uint8_t>(FastAxis::kSine) ||
            static_cast<uint8_t>(c.spiral_mode) > static_cast<uint8_t>(SpiralMode::kConstantLinearVelocity))
            r.mark_bad();
    }
};

// The group id, then the axis: an axis's group (limits, feedforward,
// feedback, rc, trajectory) names its axis, a board group (recorder, link,
// input_matrix, output_matrix) axis 0.
struct GetParams {
    static constexpr MsgType kType = MsgType::kGetParams;
    ParamGroup group = ParamGroup::kLimits;
    uint8_t axis = 0;
    bool operator==(const GetParams&) const = default;
    void write(Writer& w) const {
        w.u8(static_cast<uint8_t>(group));
        w.u8(axis);
    }
    void read(Reader& r) {
        group = static_cast<ParamGroup>(r.u8());
        axis = r.u8();
    }
};

// SetParams<G> (request) and ParamsReply<G> (reply to GetParams): the group
// id, the axis (as GetParams'), then the group's layout.
template <MsgType Type, class G>
struct GroupMessage {
    static constexpr MsgType kType = Type;
    G value{};
    uint8_t axis = 0;  // second on the wire
    bool operator==(const GroupMessage&) const = default;
    void write(Writer& w) const {
        w.u8(static_cast<uint8_t>(G::kGroup));
        w.u8(axis);
        params::write_group(w, value);
    }
    void read(Reader& r) {
        if (r.u8() != static_cast<uint8_t>(G::kGroup)) r.mark_bad();
        axis = r.u8();
        params::read_group(r, value);
    }
};
template <class G> using SetParams = GroupMessage<MsgType::kSetParams, G>;
template <class G> using ParamsReply = GroupMessage<MsgType::kParamsReply, G>;

// Group id of a SetParams / ParamsReply body (0 if empty).
constexpr uint8_t body_group(std::span<const uint8_t> body) { return body.empty() ? 0 : body[0]; }

// The stream feeds one axis's setpoint (the others keep theirs).
struct StreamStart {
    static constexpr MsgType kType = MsgType::kStreamStart;
    uint16_t prefill = 0;  // setpoints buffered before the tick starts consuming
    uint8_t axis = 0;      // first on the wire
    bool operator==(const StreamStart&) const = default;
    void write(Writer& w) const {
        w.u8(axis);
        w.u16(prefill);
    }
    void read(Reader& r) {
        axis = r.u8();
        prefill = r.u16();
    }
};

struct StreamStop {
    static constexpr MsgType kType = MsgType::kStreamStop;
    bool drain = true;  // consume what is buffered first (no underrun at the end)
    bool operator==(const StreamStop&) const = default;
    void write(Writer& w) const { w.boolean(drain); }
    void read(Reader& r) { drain = r.boolean(); }
};

// A block of setpoints (µm), consumed one per tick.
struct SetpointBlock;
template <class V, params::GroupRef<SetpointBlock> M>
constexpr void describe(V& v, M& m) {
    using namespace params;
    v.value(u32("block_seq", "1", "0 for the first block after StreamStart, +1 per block"), m.block_seq);
    v.count(u8("count", "setpoints in the block, 0..120").range(0, kMaxSetpointsPerBlock), m.count);
    v.values(f32("setpoint_um", "um", "finite, within +-1e6 um"), m.setpoint_um, m.count, Travel::kCount);
}

struct SetpointBlock {
    static constexpr MsgType kType = MsgType::kSetpoints;
    uint32_t block_seq = 0;  // 0 for the first block after StreamStart, +1 per block
    uint8_t count = 0;
    std::array<float, kMaxSetpointsPerBlock> setpoint_um{};
    bool operator==(const SetpointBlock&) const = default;
    void write(Writer& w) const { params::write_group(w, *this); }
    void read(Reader& r) { params::read_group(r, *this); }
};

struct SetpointAck;
template <class V, params::GroupRef<SetpointAck> M>
constexpr void describe(V& v, M& m) {
    using namespace params;
    v.value(u32("next_block_seq", "1", "the block the device expects next"), m.next_block_seq);
    v.value(u16("free", "free FIFO slots (setpoints) after this block"), m.free);
    v.value(u16("capacity", "FIFO slots"), m.capacity);
    v.value(u32("underruns", "ticks", "ticks that found the FIFO empty since StreamStart"), m.underruns);
    v.value(u32("consumed", "1", "setpoints consumed since StreamStart"), m.consumed);
}

struct SetpointAck {
    static constexpr MsgType kType = MsgType::kSetpointAck;
    uint32_t next_block_seq = 0;  // the block the device expects next
    uint16_t free = 0;            // free FIFO slots (setpoints) after this block
    uint16_t capacity = 0;
    uint32_t underruns = 0;       // ticks that found the FIFO empty since StreamStart
    uint32_t consumed = 0;        // setpoints consumed since StreamStart
    bool operator==(const SetpointAck&) const = default;
    void write(Writer& w) const { params::write_group(w, *this); }
    void read(Reader& r) { params::read_group(r, *this); }
};

struct Ack {
    static constexpr MsgType kType = MsgType::kAck;
    uint8_t request_type = 0;
    bool operator==(const Ack&) const = default;
    void write(Writer& w) const { w.u8(request_type); }
    void read(Reader& r) { request_type = r.u8(); }
};

// Error reply. group/field/message are the core's Status texts (group empty
// for top-level fields), index the array element or -1.
struct ErrorReply;
template <class V, params::GroupRef<ErrorReply> M>
constexpr void describe(V& v, M& m) {
    using namespace params;
    v.value(u8("request_type", "the request's type"), m.request_type);
    v.value(u8("code", "the error code (below)"), m.code);
    v.text(text("group", "parameter group or block, e.g. `limits`, `feedforward`, `feedback`, `rc`, `trajectory`; empty for "
                         "top-level fields"),
           m.group);
    v.text(text("field", "the offending field, e.g. `u_max_V`, `weights`, `sections`, `kind`"), m.field);
    v.value(i16("index", "1", "array element, -1 if none"), m.index);
    v.text(text("message", "what is allowed, e.g. `must be finite and <= the hard limit u_max_V`"), m.message);
}

struct ErrorReply {
    static constexpr MsgType kType = MsgType::kError;
    uint8_t request_type = 0;
    ErrorCode code = ErrorCode::kNone;
    std::array<char, kGroupTextSize> group{};
    std::array<char, kFieldTextSize> field{};
    int16_t index = -1;
    std::array<char, kMessageTextSize> message{};
    bool operator==(const ErrorReply&) const = default;

    void write(Writer& w) const { params::write_group(w, *this); }
    void read(Reader& r) { params::read_group(r, *this); }
};

// Copies a C string into a fixed text array (cut, zero-terminated).
template <std::size_t N>
constexpr void set_text(std::array<char, N>& out, const char* s) {
    out = {};
    if (s == nullptr) return;
    for (std::size_t i = 0; i + 1 < N && s[i] != '\0'; ++i) out[i] = s[i];
}

constexpr ErrorReply make_error(uint8_t request_type, ErrorCode code, const Status& s) {
    ErrorReply e;
    e.request_type = request_type;
    e.code = code;
    set_text(e.group, s.group);
    set_text(e.field, s.field);
    e.index = static_cast<int16_t>(s.index < -1 ? -1 : (s.index > 32767 ? 32767 : s.index));
    set_text(e.message, s.message);
    return e;
}

struct HelloReply;
template <class V, params::GroupRef<HelloReply> M>
constexpr void describe(V& v, M& m) {
    using namespace params;
    v.value(u8("protocol_version", "the device's protocol version"), m.protocol_version);
    v.text(text("board", "e.g. `qemu-m7`"), m.board);
    v.text(text("firmware_version", "the project version the firmware was built from"), m.firmware_version);
    v.text(text("serial", "up to 31 characters, zero-padded (STM32: the 96-bit unique ID as 24 hex digits)"), m.serial);
    v.value(f32("loop_rate_Hz", "Hz", "control tick rate"), m.loop_rate_Hz);
    v.value(u32("capabilities", "1",
                "bit 0 float pipeline, 1 Q31 pipeline, 2 Dahl, 3 repetitive control, 4 setpoint stream, 5 recorder, "
                "6 wave tables, 7 excitation, 8 parameter storage (Save / Load / Forget), 9 axis matrices, 10 scans"),
            m.capabilities);
    v.value(u8("sample_format", "0 float32 (physical units), 1 Q31"), m.sample_format);
    v.value(f32("hard_u_min_V", "V", "board hard limits: never exceeded"), m.hard_u_min_V);
    v.value(f32("hard_u_max_V", "V", "board hard limit"), m.hard_u_max_V);
    v.value(f32("hard_slew_max_V_per_s", "V/s", "board hard slew limit"), m.hard_slew_max_V_per_s);
    v.value(f32("position_full_scale_um", "um", "Q31 full scale of r, y, e"), m.position_full_scale_um);
    v.value(f32("voltage_full_scale_V", "V", "Q31 full scale of u, u_ff, u_fb, u_rc (and d at the command)"),
            m.voltage_full_scale_V);
    v.value(u16("max_payload", "largest payload, bytes: 512"), m.max_payload);
    v.value(u16("setpoint_capacity", "setpoint FIFO slots"), m.setpoint_capacity);
    v.value(u8("recorder_channels", "channel count the recorder group must use"), m.recorder_channels);
    v.value(u32("recorder_capacity", "frames", "recorder ring, frames"), m.recorder_capacity);
    v.value(u8("max_sos_sections", "feedback SOS sections: 4"), m.max_sos_sections);
    v.value(u8("max_play_operators", "PI play operators: 16"), m.max_play_operators);
    v.value(u16("max_wave_table", "points of a steps / table wave: 96"), m.max_wave_table);
    v.value(u32("rc_capacity", "samples", "largest RC period, samples"), m.rc_capacity);
    v.value(u32("excitation_capacity", "samples",
                "longest multisine period, samples (16384 on the QEMU boards, 4096 on the STM32)"),
            m.excitation_capacity);
    // The axes: the fields above are axis 0's, these every axis's.
    v.count(u8("axis_count", "axes the board runs, 1..3 (axis:u8 of the requests is below it)"), m.axis_count);
    v.values(f32("axis_hard_u_min_V", "V", "each axis's (and its channel's) hard limits"), m.axis_hard_u_min_V,
             m.axis_count, Travel::kCount);
    v.values(f32("axis_hard_u_max_V", "V", "..."), m.axis_hard_u_max_V, m.axis_count, Travel::kCount);
    v.values(f32("axis_hard_slew_max_V_per_s", "V/s", "..."), m.axis_hard_slew_max_V_per_s, m.axis_count,
             Travel::kCount);
    v.values(f32("axis_position_full_scale_um", "um", "each axis's Q31 full scale of r, y, e"),
             m.axis_position_full_scale_um, m.axis_count, Travel::kCount);
    v.values(f32("axis_voltage_full_scale_V", "V", "each axis's Q31 full scale of u, u_ff, u_fb, u_rc"),
             m.axis_voltage_full_scale_V, m.axis_count, Travel::kCount);
}

struct HelloReply {
    static constexpr MsgType kType = MsgType::kHelloReply;
    uint8_t protocol_version = kProtocolVersion;
    std::array<char, kNameSize> board{};
    std::array<char, kNameSize> firmware_version{};
    std::array<char, kSerialSize> serial{};
    float loop_rate_Hz = 0.0f;
    uint32_t capabilities = 0;
    SampleFormat sample_format = SampleFormat::kFloat32;
    float hard_u_min_V = 0.0f, hard_u_max_V = 0.0f, hard_slew_max_V_per_s = 0.0f;
    float position_full_scale_um = 0.0f;  // Q31 full scales of r, y, e (µm) and u, u_ff, u_fb, u_rc (V)
    float voltage_full_scale_V = 0.0f;
    uint16_t max_payload = static_cast<uint16_t>(kMaxPayload);
    uint16_t setpoint_capacity = 0;
    uint8_t recorder_channels = 0;  // channel count the recorder group must use
    uint32_t recorder_capacity = 0;
    uint8_t max_sos_sections = kMaxControllerSections;
    uint8_t max_play_operators = kMaxPlayOperators;
    uint16_t max_wave_table = static_cast<uint16_t>(kMaxWaveTable);
    uint32_t rc_capacity = 0;  // largest RC period, samples
    uint32_t excitation_capacity = 0;  // longest multisine period, samples
    uint8_t axis_count = 1;
    std::array<float, kMaxLinkAxes> axis_hard_u_min_V{}, axis_hard_u_max_V{}, axis_hard_slew_max_V_per_s{};
    std::array<float, kMaxLinkAxes> axis_position_full_scale_um{}, axis_voltage_full_scale_V{};
    bool operator==(const HelloReply&) const = default;

    void write(Writer& w) const { params::write_group(w, *this); }
    void read(Reader& r) { params::read_group(r, *this); }
};

// Fault bits of the status reply.
namespace fault {
inline constexpr uint32_t kHardLimitsInvalid = 1u << 0;  // limiter permanently tripped
inline constexpr uint32_t kTickOverrun = 1u << 1;        // the tick missed a period at least once
inline constexpr uint32_t kSetpointUnderrun = 1u << 2;   // streamed setpoints ran out at least once
inline constexpr uint32_t kRecorderOverrun = 1u << 3;    // log frames dropped since recorder arm
inline constexpr uint32_t kLinkErrors = 1u << 4;         // link counters show dropped frames
inline constexpr uint32_t kClientLost = 1u << 5;         // a stream or wave was stopped: its client went silent
inline constexpr uint32_t kBoardFault = 1u << 8;         // bits 8..31: board-specific (TickStats::board_faults)
}  // namespace fault

// Tick timing the firmware measures; handed to the dispatcher (set_tick_stats).
struct TickStats {
    uint32_t overruns = 0;       // periods the loop did not serve on time
    uint32_t time_min = 0;       // per-tick execution time, in counter units
    uint32_t time_max = 0;
    float time_mean = 0.0f;
    float counter_Hz = 0.0f;     // counter units per second (0: unknown)
    uint32_t board_faults = 0;   // board-specific fault bits (shifted into bits 8..31)
    bool operator==(const TickStats&) const = default;
};

// What became of the stored parameter set at boot (StatusReply::storage).
enum class StorageState : uint8_t {
    kAbsent = 0,         // the board has no storage (emulated: started without --storage)
    kEmpty = 1,          // nothing stored: the board booted with its safe default
    kApplied = 2,        // the stored set was validated and applied
    kCorrupt = 3,        // ignored: magic, length or CRC wrong, or the record is cut short
    kOtherFirmware = 4,  // ignored: written by another firmware version or record format
    kRejected = 5,       // ignored: the set failed validation (group/field/message say why)
    kReadFailed = 6,     // ignored: the storage could not be read
};
inline constexpr uint8_t kStorageStateCount = 7;

constexpr const char* storage_state_name(StorageState s) {
    switch (s) {
        case StorageState::kAbsent: return "absent";
        case StorageState::kEmpty: return "empty";
        case StorageState::kApplied: return "applied";
        case StorageState::kCorrupt: return "ignored_corrupt";
        case StorageState::kOtherFirmware: return "ignored_other_firmware";
        case StorageState::kRejected: return "ignored_rejected";
        case StorageState::kReadFailed: return "ignored_read_failed";
    }
    return "?";
}

struct StatusReply;
template <class V, params::GroupRef<StatusReply> M>
constexpr void describe(V& v, M& m) {
    using namespace params;
    v.value(boolean("armed", "the loop is armed"), m.armed);
    v.value(boolean("tripped", "the limiter is tripped"), m.tripped);
    v.value(u8("trip_reason", "0 none, 1 not configured, 2 invalid hard limits, 3 non-finite input, 4 sustained "
                              "saturation, 5 external"),
            m.trip_reason);
    v.value(boolean("wave_running", "a wave runs (its approach included)"), m.wave_running);
    v.value(boolean("streaming", "a setpoint stream runs"), m.streaming);
    v.value(boolean("swap_pending", "a parameter set waits for its swap"), m.swap_pending);
    v.value(u8("recorder_state", "0 idle, 1 armed, 2 triggered, 3 done"), m.recorder_state);
    v.value(u32("faults", "1",
                "bit 0 hard limits invalid, 1 tick overrun seen, 2 setpoint underrun seen, 3 recorder overrun, 4 link "
                "errors counted, 5 client lost (section 5a), 8..31 board-specific"),
            m.faults);
    v.value(u32("tick_count", "ticks", "ticks since boot (wraps)"), m.tick_count);
    v.value(u32("swaps", "1", "parameter sets swapped in"), m.swaps);
    v.begin("tick");
    v.value(u32("overruns", "1", "periods the loop did not serve on time"), m.tick.overruns);
    v.value(u32("time_min", "counter units", "shortest tick"), m.tick.time_min);
    v.value(u32("time_max", "counter units", "longest tick"), m.tick.time_max);
    v.value(f32("time_mean", "counter units", "mean tick"), m.tick.time_mean);
    v.value(f32("counter_Hz", "Hz", "counter units per second (0: unknown; the QEMU boards count instructions)"),
            m.tick.counter_Hz);
    v.value(u32("board_faults", "1", "board-specific fault bits"), m.tick.board_faults);
    v.end();
    v.value(u32("setpoint_underruns", "ticks", "ticks that found the setpoint FIFO empty"), m.setpoint_underruns);
    v.value(u16("setpoint_free", "free setpoint FIFO slots"), m.setpoint_free);
    v.value(u32("setpoint_next_seq", "1", "the setpoint block the device expects next"), m.setpoint_next_seq);
    v.value(u32("recorder_overruns", "frames", "frames the recorder dropped since arm"), m.recorder_overruns);
    v.value(u32("log_blocks", "1", "log blocks sent since RecorderArm"), m.log_blocks);
    v.begin("link");
    v.value(u32("frames_ok", "1", "frames with a good CRC (section 6 has the counters)"), m.link.frames_ok);
    v.value(u32("bad_cobs", "1", "frames dropped: COBS"), m.link.bad_cobs);
    v.value(u32("bad_crc", "1", "frames dropped: CRC"), m.link.bad_crc);
    v.value(u32("truncated", "1", "frames dropped: too short"), m.link.truncated);
    v.value(u32("oversize", "1", "frames dropped: too long"), m.link.oversize);
    v.value(u32("unknown_type", "1", "unknown message types"), m.link.unknown_type);
    v.value(u32("bad_version", "1", "requests of another protocol version"), m.link.bad_version);
    v.value(u32("bad_length", "1", "bodies longer than their layout"), m.link.bad_length);
    v.value(u32("bad_value", "1", "bodies with a bad bool, count or group"), m.link.bad_value);
    v.value(u32("error_replies", "1", "Error replies sent"), m.link.error_replies);
    v.end();
    v.value(f32("r_um", "um", "last tick's reference"), m.r_um);
    v.value(f32("y_um", "um", "last tick's reading"), m.y_um);
    v.value(f32("u_V", "V", "last tick's command"), m.u_V);
    v.value(boolean("excitation_running", "an excitation runs"), m.excitation_running);
    v.value(u32("excitation_ticks", "ticks", "ticks the last excitation ran"), m.excitation_ticks);
    v.value(u32("excitation_clipped", "ticks", "of those, ticks the limiter clamped or slew-limited"),
            m.excitation_clipped);
    // The storage block, the last of the layout: what became of the stored
    // parameter set at boot.
    v.value(u8("storage", "stored set at boot (section 4a): 0 absent (no storage), 1 empty (nothing stored), 2 "
                          "applied, 3 ignored: corrupt, 4 ignored: other firmware version, 5 ignored: rejected by "
                          "validation, 6 ignored: storage unreadable"),
            m.storage);
    v.text(text("storage_group", "why it was ignored, as an Error's group (empty when applied or absent)"),
           m.storage_group);
    v.text(text("storage_field", "... field"), m.storage_field);
    v.value(i16("storage_index", "1", "... index"), m.storage_index);
    v.text(text("storage_message", "... message"), m.storage_message);
    // The axes block: the fields above that belong to an axis (armed,
    // tripped, trip_reason, wave_running, excitation_*, r_um, y_um, u_V)
    // are axis 0's; these are every axis's, and each actuator channel's.
    v.count(u8("axis_count", "axes, as in the hello"), m.axis_count);
    v.values(boolean("axis_armed", "each axis armed"), m.axis_armed, m.axis_count, Travel::kCount);
    v.values(boolean("axis_tripped", "each axis's limiter tripped"), m.axis_tripped, m.axis_count, Travel::kCount);
    v.values(u8("axis_trip_reason", "as trip_reason"), m.axis_trip_reason, m.axis_count, Travel::kCount);
    v.values(boolean("axis_wave_running", "each axis's wave runs"), m.axis_wave_running, m.axis_count,
             Travel::kCount);
    v.values(boolean("axis_excitation_running", "each axis's excitation runs"), m.axis_excitation_running,
             m.axis_count, Travel::kCount);
    v.values(u32("axis_swaps", "1", "parameter sets swapped in"), m.axis_swaps, m.axis_count, Travel::kCount);
    v.values(u32("axis_excitation_ticks", "ticks", "as excitation_ticks"), m.axis_excitation_ticks, m.axis_count,
             Travel::kCount);
    v.values(u32("axis_excitation_clipped", "ticks", "as excitation_clipped"), m.axis_excitation_clipped,
             m.axis_count, Travel::kCount);
    v.values(f32("axis_r_um", "um", "last tick's reference"), m.axis_r_um, m.axis_count, Travel::kCount);
    v.values(f32("axis_y_um", "um", "last tick's position (after the input matrix)"), m.axis_y_um, m.axis_count,
             Travel::kCount);
    v.values(f32("axis_u_V", "V", "last tick's axis command"), m.axis_u_V, m.axis_count, Travel::kCount);
    v.values(f32("channel_u_V", "V", "last tick's channel command (after the output matrix and the channel limits)"),
             m.channel_u_V, m.axis_count, Travel::kCount);
    v.values(u32("channel_clamped", "ticks", "ticks the channel limiter clamped to its hard range"),
             m.channel_clamped, m.axis_count, Travel::kCount);
    v.values(u32("channel_slew_limited", "ticks", "ticks the channel limiter slew-limited"), m.channel_slew_limited,
             m.axis_count, Travel::kCount);
    // The scan block (protocol 6).
    v.value(u8("scan_state", "0 none since boot, 1 approaching its first point, 2 scanning, 3 ended (its frames, or a stop)"),
            m.scan_state);
    v.value(u32("scan_approach_ticks", "ticks", "the last scan's approach"), m.scan_approach_ticks);
    v.value(u32("scan_ticks", "ticks", "ticks the last scan ran, approach included"), m.scan_ticks);
    v.value(u32("scan_frames_completed", "1", "frames the last scan completed"), m.scan_frames_completed);
}

struct StatusReply {
    static constexpr MsgType kType = MsgType::kStatusReply;
    bool armed = false;
    bool tripped = false;
    TripReason trip_reason = TripReason::kNone;
    bool wave_running = false;
    bool streaming = false;
    bool swap_pending = false;
    RecorderState recorder_state = RecorderState::kIdle;
    uint32_t faults = 0;
    uint32_t tick_count = 0;
    uint32_t swaps = 0;
    TickStats tick{};
    uint32_t setpoint_underruns = 0;
    uint16_t setpoint_free = 0;
    uint32_t setpoint_next_seq = 0;  // the setpoint block the device expects next
    uint32_t recorder_overruns = 0;
    uint32_t log_blocks = 0;  // log blocks sent since recorder arm
    LinkCounters link{};
    float r_um = 0.0f, y_um = 0.0f, u_V = 0.0f;  // last tick's signals
    // The excitation (StartExcitation): running, ticks it ran, and of those
    // the ticks the limiter clamped or slew-limited.
    bool excitation_running = false;
    uint32_t excitation_ticks = 0;
    uint32_t excitation_clipped = 0;
    // ---- storage block (protocol 3): the stored parameter set at boot.
    // One contiguous block, the last of the layout. The texts say why a set was ignored
    // (the core's Status of the check that failed), empty otherwise.
    StorageState storage = StorageState::kAbsent;
    std::array<char, kGroupTextSize> storage_group{};
    std::array<char, kFieldTextSize> storage_field{};
    int16_t storage_index = -1;
    std::array<char, kMessageTextSize> storage_message{};
    // ---- end of the storage block
    // ---- axes block (protocol 5)
    uint8_t axis_count = 1;
    std::array<bool, kMaxLinkAxes> axis_armed{}, axis_tripped{}, axis_wave_running{}, axis_excitation_running{};
    std::array<uint8_t, kMaxLinkAxes> axis_trip_reason{};
    std::array<uint32_t, kMaxLinkAxes> axis_swaps{}, axis_excitation_ticks{}, axis_excitation_clipped{};
    std::array<float, kMaxLinkAxes> axis_r_um{}, axis_y_um{}, axis_u_V{}, channel_u_V{};
    std::array<uint32_t, kMaxLinkAxes> channel_clamped{}, channel_slew_limited{};
    // ---- scan block (protocol 6)
    uint8_t scan_state = 0;
    uint32_t scan_approach_ticks = 0, scan_ticks = 0, scan_frames_completed = 0;
    bool operator==(const StatusReply&) const = default;

    void write(Writer& w) const { params::write_group(w, *this); }
    void read(Reader& r) { params::read_group(r, *this); }
};

// Recorder frames, sent by the device. Frame i was recorded at tick
// first_tick + i * tick_stride (a gap in the ticks starts a new block).
// Samples are frame-major: frame 0 channel 0, frame 0 channel 1, ...
// float32 in physical units (µm, V), or Q31 raw (times the full scale of the
// hello reply / 2^31 gives µm or V).
struct LogBlock;
template <class V, params::GroupRef<LogBlock> M>
constexpr void describe(V& v, M& m) {
    using namespace params;
    v.value(u32("block_seq", "1", "0 for the first block after RecorderArm, +1 per block"), m.block_seq);
    v.value(u32("first_tick", "ticks", "tick index of frame 0"), m.first_tick);
    v.value(u32("tick_stride", "ticks", "the decimation; frame i is at first_tick + i*stride"), m.tick_stride);
    v.value(u32("recorder_overruns", "frames", "frames the recorder dropped since arm (cumulative)"),
            m.recorder_overruns);
    v.value(u8("channel_count", "channels per frame, 0..8"), m.channel_count);
    v.value(u8("format", "0 float32 (um / V), 1 Q31 (raw * full scale / 2^31)"), m.format);
    v.value(u8("frame_count", "frames in the block"), m.frame_count);
    v.value(u8("flags", "bit 0 last block of a single-shot record"), m.flags);
    v.values(u8("channels", "each channel: axis * 8 + signal id (on axis 0 the signal id)"), m.channels,
             kMaxLogChannels, Travel::kAll);
    // count = channel_count * frame_count; a channel count beyond the
    // layout's makes it beyond the array too (malformed).
    const std::size_t count = m.channel_count <= kMaxLogChannels
                                  ? std::size_t{m.channel_count} * m.frame_count
                                  : m.samples.size() + 1;
    v.values(u32("samples", "1", "count = channel_count*frame_count 32-bit samples, frame-major (f0c0, f0c1, ...)"),
             m.samples, count, Travel::kCount);
}

struct LogBlock {
    static constexpr MsgType kType = MsgType::kLogBlock;
    uint32_t block_seq = 0;         // 0 for the first block after recorder arm, +1 per block
    uint32_t first_tick = 0;
    uint32_t tick_stride = 1;       // the recorder decimation
    uint32_t recorder_overruns = 0; // frames the recorder dropped since arm (cumulative)
    uint8_t channel_count = 0;
    SampleFormat format = SampleFormat::kFloat32;
    uint8_t frame_count = 0;
    uint8_t flags = 0;              // bit 0: last block of a single-shot record
    std::array<uint8_t, kMaxLogChannels> channels{};  // axis * kSignalCount + SignalId of each channel
    std::array<uint32_t, (kMaxBody - kLogBlockHeader) / 4> samples{};  // raw 32-bit patterns
    bool operator==(const LogBlock&) const = default;

    static constexpr uint8_t kFlagLast = 1;

    void write(Writer& w) const { params::write_group(w, *this); }
    void read(Reader& r) { params::read_group(r, *this); }
};

// ---- whole frames --------------------------------------------------------------

// Encodes message m with sequence id seq into out (at least kMaxFrameSize
// bytes is always enough). Returns the frame length, 0 if it does not fit.
template <class M>
std::size_t encode_message(const M& m, uint16_t seq, std::span<uint8_t> out, uint8_t version = kProtocolVersion) {
    std::array<uint8_t, kMaxPayload + kCrcSize> scratch{};
    Writer w(std::span<uint8_t>(scratch.data(), kMaxPayload));
    w.u8(static_cast<uint8_t>(M::kType));
    w.u8(version);
    w.u16(seq);
    m.write(w);
    if (!w.ok()) return 0;
    return seal_frame(scratch, w.size(), out);
}

enum class DecodeResult : uint8_t { kOk, kTruncated, kTooLong, kBadValue };

// Decodes a message body (the payload after the header) into m.
template <class M>
DecodeResult decode_body(std::span<const uint8_t> body, M& m) {
    Reader r(body);
    m.read(r);
    if (!r.ok()) return DecodeResult::kTruncated;
    if (r.bad_value()) return DecodeResult::kBadValue;
    if (r.remaining() != 0) return DecodeResult::kTooLong;
    return DecodeResult::kOk;
}

}  // namespace piezoloop::link
