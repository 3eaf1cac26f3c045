// Message layouts of the link protocol (docs/protocol.md has them as tables).
//
// Every message is a struct with its type id (kType), write(Writer&) and
// read(Reader&) that follow its layout field by field, little-endian, with no
// padding and no optional fields: the layout of a type is fixed for a protocol
// version (variable-length arrays travel with their count and only that many
// elements). Requests come from the host, replies echo the request's sequence
// id, log blocks are sent by the device unasked.
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
#include "piezoloop/params/groups.hpp"
#include "piezoloop/params/wire_codec.hpp"
#include "piezoloop/pi_model.hpp"
#include "piezoloop/pid.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/recorder.hpp"
#include "piezoloop/repetitive.hpp"
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
inline constexpr uint8_t kProtocolVersion = 4;

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

constexpr bool is_request(uint8_t t) { return (t >= 0x01 && t <= 0x13); }

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
inline constexpr std::array<MessageTypeDoc, 26> kMessageTypes = {{
    {MsgType::kHello, "Hello", "empty", "HelloReply"},
    {MsgType::kGetStatus, "GetStatus", "empty", "StatusReply"},
    {MsgType::kGetParams, "GetParams", "group:u8", "ParamsReply"},
    {MsgType::kSetParams, "SetParams", "group:u8 + group layout", "Ack / Error"},
    {MsgType::kArm, "Arm", "empty", "Ack / Error(tripped)"},
    {MsgType::kDisarm, "Disarm", "empty", "Ack"},
    {MsgType::kClearTrip, "ClearTrip", "empty", "Ack / Error(armed, tripped)"},
    {MsgType::kStartWave, "StartWave", "empty, or u8 flags (runs the trajectory group; see below)", "Ack / Error"},
    {MsgType::kStopWave, "StopWave", "empty", "Ack"},
    {MsgType::kStreamStart, "StreamStart", "prefill:u16", "SetpointAck"},
    {MsgType::kSetpoints, "Setpoints", "SetpointBlock", "SetpointAck / Error"},
    {MsgType::kStreamStop, "StreamStop", "drain:bool", "Ack"},
    {MsgType::kRecorderArm, "RecorderArm", "empty", "Ack / Error(not_configured)"},
    {MsgType::kRecorderStop, "RecorderStop", "empty", "Ack"},
    {MsgType::kStartExcitation, "StartExcitation", "see below", "Ack / Error"},
    {MsgType::kStopExcitation, "StopExcitation", "empty", "Ack"},
    {MsgType::kSave, "Save", "empty", "Ack / Error(unsupported, armed, invalid_param, storage)"},
    {MsgType::kLoad, "Load", "empty",
     "Ack / Error(unsupported, armed, not_configured, storage, invalid_param, busy)"},
    {MsgType::kForget, "Forget", "empty", "Ack / Error(unsupported, armed, storage)"},
    {MsgType::kAck, "Ack", "request_type:u8", ""},
    {MsgType::kHelloReply, "HelloReply", "see below", ""},
    {MsgType::kStatusReply, "StatusReply", "see below", ""},
    {MsgType::kParamsReply, "ParamsReply", "group:u8 + group layout", ""},
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
}  // namespace cap

enum class SampleFormat : uint8_t { kFloat32 = 0, kQ31 = 1 };

inline constexpr std::size_t kNameSize = 16;          // board, firmware version
inline constexpr std::size_t kSerialSize = 32;         // up to 31 characters
inline constexpr std::size_t kGroupTextSize = 16;     // error reply texts
inline constexpr std::size_t kFieldTextSize = 32;
inline constexpr std::size_t kMessageTextSize = 96;
inline constexpr std::size_t kMaxSetpointsPerBlock = 120;
inline constexpr std::size_t kLogBlockHeader = 28;    // body bytes before the samples
// Samples per log block: 480 bytes of samples whatever the channel count.
constexpr std::size_t log_frames_per_block(std::size_t channels) {
    return channels == 0 ? 0 : ((kMaxBody - kLogBlockHeader) / (4 * channels) > 255
                                    ? 255
                                    : (kMaxBody - kLogBlockHeader) / (4 * channels));
}

// ---- parameter groups ------------------------------------------------------
// Declared once, with their layouts, in params/groups.hpp.

using params::FeedbackParams;
using params::FeedforwardParams;
using params::group_name;
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
using StopWave = EmptyMessage<MsgType::kStopWave>;
using RecorderArm = EmptyMessage<MsgType::kRecorderArm>;
using RecorderStop = EmptyMessage<MsgType::kRecorderStop>;
using StopExcitation = EmptyMessage<MsgType::kStopExcitation>;

// Runs the trajectory group's wave. The body is optional (empty = flags 0,
// as in the first clients): flags make the wave's first sample, the loop's
// arm, the recorder's arm and a restart of the emulated stage happen at the
// same tick boundary, so the first recorded frame is the wave's tick 0 with
// the loop freshly armed and the stage at rest (how `piezoloop sim` starts).
struct StartWave {
    static constexpr MsgType kType = MsgType::kStartWave;
    static constexpr uint8_t kArmLoop = 1u << 0;       // arm the loop (refused if already armed)
    static constexpr uint8_t kArmRecorder = 1u << 1;   // arm the recorder (configured first)
    static constexpr uint8_t kRestartStage = 1u << 2;  // emulated stage back at rest (DeviceHooks::restart_stage)
    static constexpr uint8_t kDetached = 1u << 3;      // the wave runs on when the client goes silent
    static constexpr uint8_t kKnownFlags = kArmLoop | kArmRecorder | kRestartStage | kDetached;
    uint8_t flags = 0;
    bool operator==(const StartWave&) const = default;
    // Flags 0 travel as the empty body, byte for byte the old message, and
    // only so: a body byte 0 is left unread (too long, malformed), which
    // keeps one encoding per value.
    void write(Writer& w) const {
        if (flags != 0) w.u8(flags);
    }
    void read(Reader& r) {
        flags = 0;
        if (r.remaining() == 0) return;
        Reader probe = r;
        if (probe.u8() == 0) return;
        flags = r.u8();
    }
};

// Starts an excitation (excitation.hpp) at the next tick: a signal d added
// at the command or the reference, for measurements (`piezoloop measure`).
// The flags work as StartWave's: the excitation's first sample, the loop's
// arm, the recorder's arm and the emulated stage's restart happen at one
// tick boundary, so the first recorded frame is the excitation's sample 0.
// The sample rate is the device's loop rate.
struct StartExcitation {
    static constexpr MsgType kType = MsgType::kStartExcitation;
    static constexpr uint8_t kArmLoop = StartWave::kArmLoop;
    static constexpr uint8_t kArmRecorder = StartWave::kArmRecorder;
    static constexpr uint8_t kRestartStage = StartWave::kRestartStage;
    static constexpr uint8_t kDetached = StartWave::kDetached;
    static constexpr uint8_t kKnownFlags = StartWave::kKnownFlags;
    uint8_t flags = 0;
    ExcitationConfig config{};  // sample_rate_Hz is not sent
    bool operator==(const StartExcitation& o) const {
        const ExcitationConfig &a = config, &b = o.config;
        return flags == o.flags && a.signal == b.signal && a.point == b.point && a.amplitude == b.amplitude &&
               a.offset == b.offset && a.period_samples == b.period_samples && a.first_bin == b.first_bin &&
               a.last_bin == b.last_bin && a.f1_Hz == b.f1_Hz && a.f2_Hz == b.f2_Hz &&
               a.prbs_order == b.prbs_order && a.prbs_hold == b.prbs_hold && a.periods == b.periods;
    }
    void write(Writer& w) const {
        const ExcitationConfig& c = config;
        w.u8(flags); w.u8(static_cast<uint8_t>(c.signal)); w.u8(static_cast<uint8_t>(c.point));
        w.f32(c.amplitude); w.f32(c.offset);
        w.u32(c.period_samples); w.u32(c.first_bin); w.u32(c.last_bin);
        w.f32(c.f1_Hz); w.f32(c.f2_Hz);
        w.u8(static_cast<uint8_t>(c.prbs_order)); w.u32(c.prbs_hold); w.u32(c.periods);
    }
    void read(Reader& r) {
        ExcitationConfig& c = config;
        flags = r.u8(); c.signal = static_cast<ExcitationSignal>(r.u8()); c.point = static_cast<ExcitationPoint>(r.u8());
        c.amplitude = r.f32(); c.offset = r.f32();
        c.period_samples = r.u32(); c.first_bin = r.u32(); c.last_bin = r.u32();
        c.f1_Hz = r.f32(); c.f2_Hz = r.f32();
        c.prbs_order = r.u8(); c.prbs_hold = r.u32(); c.periods = r.u32();
        if (c.point != ExcitationPoint::kCommand && c.point != ExcitationPoint::kReference) r.mark_bad();
    }
};

struct GetParams {
    static constexpr MsgType kType = MsgType::kGetParams;
    ParamGroup group = ParamGroup::kLimits;
    bool operator==(const GetParams&) const = default;
    void write(Writer& w) const { w.u8(static_cast<uint8_t>(group)); }
    void read(Reader& r) { group = static_cast<ParamGroup>(r.u8()); }
};

// SetParams<G> (request) and ParamsReply<G> (reply to GetParams): the group
// id, then the group's layout.
template <MsgType Type, class G>
struct GroupMessage {
    static constexpr MsgType kType = Type;
    G value{};
    bool operator==(const GroupMessage&) const = default;
    void write(Writer& w) const {
        w.u8(static_cast<uint8_t>(G::kGroup));
        params::write_group(w, value);
    }
    void read(Reader& r) {
        if (r.u8() != static_cast<uint8_t>(G::kGroup)) r.mark_bad();
        params::read_group(r, value);
    }
};
template <class G> using SetParams = GroupMessage<MsgType::kSetParams, G>;
template <class G> using ParamsReply = GroupMessage<MsgType::kParamsReply, G>;

// Group id of a SetParams / ParamsReply body (0 if empty).
constexpr uint8_t body_group(std::span<const uint8_t> body) { return body.empty() ? 0 : body[0]; }

struct StreamStart {
    static constexpr MsgType kType = MsgType::kStreamStart;
    uint16_t prefill = 0;  // setpoints buffered before the tick starts consuming
    bool operator==(const StreamStart&) const = default;
    void write(Writer& w) const { w.u16(prefill); }
    void read(Reader& r) { prefill = r.u16(); }
};

struct StreamStop {
    static constexpr MsgType kType = MsgType::kStreamStop;
    bool drain = true;  // consume what is buffered first (no underrun at the end)
    bool operator==(const StreamStop&) const = default;
    void write(Writer& w) const { w.boolean(drain); }
    void read(Reader& r) { drain = r.boolean(); }
};

// A block of setpoints (µm), consumed one per tick.
struct SetpointBlock {
    static constexpr MsgType kType = MsgType::kSetpoints;
    uint32_t block_seq = 0;  // 0 for the first block after StreamStart, +1 per block
    uint8_t count = 0;
    std::array<float, kMaxSetpointsPerBlock> setpoint_um{};
    bool operator==(const SetpointBlock&) const = default;
    void write(Writer& w) const {
        w.u32(block_seq);
        const uint8_t n = count > kMaxSetpointsPerBlock ? static_cast<uint8_t>(kMaxSetpointsPerBlock) : count;
        w.u8(n);
        for (std::size_t i = 0; i < n; ++i) w.f32(setpoint_um[i]);
    }
    void read(Reader& r) {
        block_seq = r.u32();
        count = r.u8();
        if (count > kMaxSetpointsPerBlock) { r.mark_bad(); return; }
        setpoint_um = {};
        for (std::size_t i = 0; i < count; ++i) setpoint_um[i] = r.f32();
    }
};

struct SetpointAck {
    static constexpr MsgType kType = MsgType::kSetpointAck;
    uint32_t next_block_seq = 0;  // the block the device expects next
    uint16_t free = 0;            // free FIFO slots (setpoints) after this block
    uint16_t capacity = 0;
    uint32_t underruns = 0;       // ticks that found the FIFO empty since StreamStart
    uint32_t consumed = 0;        // setpoints consumed since StreamStart
    bool operator==(const SetpointAck&) const = default;
    void write(Writer& w) const { w.u32(next_block_seq); w.u16(free); w.u16(capacity); w.u32(underruns); w.u32(consumed); }
    void read(Reader& r) { next_block_seq = r.u32(); free = r.u16(); capacity = r.u16(); underruns = r.u32(); consumed = r.u32(); }
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
struct ErrorReply {
    static constexpr MsgType kType = MsgType::kError;
    uint8_t request_type = 0;
    ErrorCode code = ErrorCode::kNone;
    std::array<char, kGroupTextSize> group{};
    std::array<char, kFieldTextSize> field{};
    int16_t index = -1;
    std::array<char, kMessageTextSize> message{};
    bool operator==(const ErrorReply&) const = default;

    void write(Writer& w) const {
        w.u8(request_type); w.u8(static_cast<uint8_t>(code));
        w.text(group.data(), kGroupTextSize); w.text(field.data(), kFieldTextSize);
        w.i16(index);
        w.text(message.data(), kMessageTextSize);
    }
    void read(Reader& r) {
        request_type = r.u8(); code = static_cast<ErrorCode>(r.u8());
        r.text(group.data(), group.size(), kGroupTextSize); r.text(field.data(), field.size(), kFieldTextSize);
        index = r.i16();
        r.text(message.data(), message.size(), kMessageTextSize);
    }
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
    bool operator==(const HelloReply&) const = default;

    void write(Writer& w) const {
        w.u8(protocol_version);
        w.text(board.data(), kNameSize); w.text(firmware_version.data(), kNameSize); w.text(serial.data(), kSerialSize);
        w.f32(loop_rate_Hz); w.u32(capabilities); w.u8(static_cast<uint8_t>(sample_format));
        w.f32(hard_u_min_V); w.f32(hard_u_max_V); w.f32(hard_slew_max_V_per_s);
        w.f32(position_full_scale_um); w.f32(voltage_full_scale_V);
        w.u16(max_payload); w.u16(setpoint_capacity); w.u8(recorder_channels); w.u32(recorder_capacity);
        w.u8(max_sos_sections); w.u8(max_play_operators); w.u16(max_wave_table); w.u32(rc_capacity);
        w.u32(excitation_capacity);
    }
    void read(Reader& r) {
        protocol_version = r.u8();
        r.text(board.data(), board.size(), kNameSize); r.text(firmware_version.data(), firmware_version.size(), kNameSize);
        r.text(serial.data(), serial.size(), kSerialSize);
        loop_rate_Hz = r.f32(); capabilities = r.u32(); sample_format = static_cast<SampleFormat>(r.u8());
        hard_u_min_V = r.f32(); hard_u_max_V = r.f32(); hard_slew_max_V_per_s = r.f32();
        position_full_scale_um = r.f32(); voltage_full_scale_V = r.f32();
        max_payload = r.u16(); setpoint_capacity = r.u16(); recorder_channels = r.u8(); recorder_capacity = r.u32();
        max_sos_sections = r.u8(); max_play_operators = r.u8(); max_wave_table = r.u16(); rc_capacity = r.u32();
        excitation_capacity = r.u32();
    }
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
    bool operator==(const StatusReply&) const = default;

    void write(Writer& w) const {
        w.boolean(armed); w.boolean(tripped); w.u8(static_cast<uint8_t>(trip_reason));
        w.boolean(wave_running); w.boolean(streaming); w.boolean(swap_pending);
        w.u8(static_cast<uint8_t>(recorder_state));
        w.u32(faults); w.u32(tick_count); w.u32(swaps);
        w.u32(tick.overruns); w.u32(tick.time_min); w.u32(tick.time_max); w.f32(tick.time_mean); w.f32(tick.counter_Hz);
        w.u32(tick.board_faults);
        w.u32(setpoint_underruns); w.u16(setpoint_free); w.u32(setpoint_next_seq); w.u32(recorder_overruns); w.u32(log_blocks);
        w.u32(link.frames_ok); w.u32(link.bad_cobs); w.u32(link.bad_crc); w.u32(link.truncated); w.u32(link.oversize);
        w.u32(link.unknown_type); w.u32(link.bad_version); w.u32(link.bad_length); w.u32(link.bad_value);
        w.u32(link.error_replies);
        w.f32(r_um); w.f32(y_um); w.f32(u_V);
        w.boolean(excitation_running); w.u32(excitation_ticks); w.u32(excitation_clipped);
        // storage block
        w.u8(static_cast<uint8_t>(storage));
        w.text(storage_group.data(), kGroupTextSize); w.text(storage_field.data(), kFieldTextSize);
        w.i16(storage_index);
        w.text(storage_message.data(), kMessageTextSize);
    }
    void read(Reader& r) {
        armed = r.boolean(); tripped = r.boolean(); trip_reason = static_cast<TripReason>(r.u8());
        wave_running = r.boolean(); streaming = r.boolean(); swap_pending = r.boolean();
        recorder_state = static_cast<RecorderState>(r.u8());
        faults = r.u32(); tick_count = r.u32(); swaps = r.u32();
        tick.overruns = r.u32(); tick.time_min = r.u32(); tick.time_max = r.u32(); tick.time_mean = r.f32(); tick.counter_Hz = r.f32();
        tick.board_faults = r.u32();
        setpoint_underruns = r.u32(); setpoint_free = r.u16(); setpoint_next_seq = r.u32(); recorder_overruns = r.u32(); log_blocks = r.u32();
        link.frames_ok = r.u32(); link.bad_cobs = r.u32(); link.bad_crc = r.u32(); link.truncated = r.u32(); link.oversize = r.u32();
        link.unknown_type = r.u32(); link.bad_version = r.u32(); link.bad_length = r.u32(); link.bad_value = r.u32();
        link.error_replies = r.u32();
        r_um = r.f32(); y_um = r.f32(); u_V = r.f32();
        excitation_running = r.boolean(); excitation_ticks = r.u32(); excitation_clipped = r.u32();
        // storage block
        storage = static_cast<StorageState>(r.u8());
        r.text(storage_group.data(), storage_group.size(), kGroupTextSize);
        r.text(storage_field.data(), storage_field.size(), kFieldTextSize);
        storage_index = r.i16();
        r.text(storage_message.data(), storage_message.size(), kMessageTextSize);
    }
};

// Recorder frames, sent by the device. Frame i was recorded at tick
// first_tick + i * tick_stride (a gap in the ticks starts a new block).
// Samples are frame-major: frame 0 channel 0, frame 0 channel 1, ...
// float32 in physical units (µm, V), or Q31 raw (times the full scale of the
// hello reply / 2^31 gives µm or V).
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
    std::array<uint8_t, kMaxLogChannels> channels{};  // SignalId of each channel
    std::array<uint32_t, (kMaxBody - kLogBlockHeader) / 4> samples{};  // raw 32-bit patterns
    bool operator==(const LogBlock&) const = default;

    static constexpr uint8_t kFlagLast = 1;

    void write(Writer& w) const {
        w.u32(block_seq); w.u32(first_tick); w.u32(tick_stride); w.u32(recorder_overruns);
        w.u8(channel_count); w.u8(static_cast<uint8_t>(format)); w.u8(frame_count); w.u8(flags);
        for (const uint8_t c : channels) w.u8(c);
        const std::size_t n = std::size_t{channel_count} * frame_count;
        for (std::size_t i = 0; i < n && i < samples.size(); ++i) w.u32(samples[i]);
    }
    void read(Reader& r) {
        block_seq = r.u32(); first_tick = r.u32(); tick_stride = r.u32(); recorder_overruns = r.u32();
        channel_count = r.u8(); format = static_cast<SampleFormat>(r.u8()); frame_count = r.u8(); flags = r.u8();
        for (uint8_t& c : channels) c = r.u8();
        const std::size_t n = std::size_t{channel_count} * frame_count;
        if (channel_count > kMaxLogChannels || n > samples.size()) { r.mark_bad(); return; }
        samples = {};
        for (std::size_t i = 0; i < n; ++i) samples[i] = r.u32();
    }
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
