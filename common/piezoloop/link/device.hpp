// Device side of the link: decodes requests from the byte stream, applies
// them to a Pipeline<T>, and produces the reply frames. No heap; the same code
// runs in the firmware main loop and in host tests.
//
// Contexts (as in the firmware):
//   main loop: receive(), poll_log(), set_tick_stats()   -- one thread
//   tick:      on_tick() just before Pipeline::begin_tick() or tick() -- the timer interrupt
// Parameter sets go through Pipeline::stage(): a new PipelineParams is built
// from the current one plus the changed group, so a rejected set leaves the
// running one untouched, and an accepted one is swapped in at the next tick.
// The recorder and the limiter trip are touched from the main loop only
// inside the mask_tick hook (the firmware masks the tick interrupt there).
//
// Limit-critical parameters change only while disarmed (ErrorCode::kArmed):
//   limits (all fields)            -- they bound the output
//   feedback pid.u_min / pid.u_max -- the PID's own output range
//   feedforward kind, feedback kind, sos_count, rc enabled
//                                  -- they replace a block, which restarts from rest
// and clear-trip is refused while armed. Everything else (gains, PI weights,
// Dahl, SOS coefficients, RC tuning) is swapped in at a tick boundary while
// armed, with the limiter (not banked) slewing the output across the change.
// A set equal to the current group is acknowledged without staging anything.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

#include "piezoloop/det_math.hpp"
#include "piezoloop/link/framing.hpp"
#include "piezoloop/link/messages.hpp"
#include "piezoloop/pipeline.hpp"

namespace piezoloop::link {

struct DeviceInfo {
    const char* board = "host";
    const char* firmware_version = "0.0.0";
    const char* serial = "";
};

struct DeviceHooks {
    // Called with true before and false after the main loop touches state the
    // tick reads non-atomically (recorder configuration, limiter trip). Null
    // on the host, where the tick runs in the same thread.
    void (*mask_tick)(bool masked) = nullptr;
    // Puts the emulated stage back at rest (plant states zero, the next
    // reading y = 0), for StartWave's kRestartStage flag; called between
    // mask_tick(true) and mask_tick(false). Returns false if it could not.
    // Null where there is no emulated stage: the flag is then refused
    // (ErrorCode::kUnsupported).
    bool (*restart_stage)() = nullptr;
};

template <class T, int RcCapacity = 1024, std::size_t RecChannels = 4, std::size_t RecCapacity = 1024,
          std::size_t SetpointCapacity = 1024>
class Device {
    static_assert(is_sample_type_v<T>, "Device<T>: T is float or Q31");
    static_assert(RecChannels >= 1 && RecChannels <= kMaxLogChannels, "log blocks carry up to 8 channels");
    static_assert(SetpointCapacity >= 2 && SetpointCapacity <= 32768 &&
                      (SetpointCapacity & (SetpointCapacity - 1)) == 0,
                  "setpoint FIFO: power of two, at most 32768");
    static constexpr bool kFloat = std::is_same_v<T, float>;

public:
    using PipelineType = Pipeline<T, RcCapacity, RecChannels, RecCapacity>;
    using RecorderType = typename PipelineType::RecorderType;
    static constexpr std::size_t kFramesPerBlock = log_frames_per_block(RecChannels);

    Device(PipelineType& pipeline, const DeviceInfo& info = {}, const DeviceHooks& hooks = {})
        : pipeline_(pipeline), info_(info), hooks_(hooks) {}

    // ---- main loop ----------------------------------------------------------

    // Feeds received bytes; send(std::span<const uint8_t>) gets each reply frame.
    template <class Send>
    void receive(std::span<const uint8_t> bytes, Send&& send) {
        decoder_.feed(bytes, [&](std::span<const uint8_t> payload) { handle_payload(payload, send); });
    }

    // One intact payload (header + body), e.g. from a transport that frames by itself.
    template <class Send>
    void handle_payload(std::span<const uint8_t> payload, Send&& send) {
        if (payload.size() < kHeaderSize) { LinkCounters::inc(counters().truncated); return; }
        const FrameHeader h = parse_header(payload);
        const std::span<const uint8_t> body = payload.subspan(kHeaderSize);
        if (h.type == static_cast<uint8_t>(MsgType::kHello)) {
            // Any version: the reply tells the client which one we speak.
            reply(make_hello(), h.seq, send);
            return;
        }
        if (h.version != kProtocolVersion) {
            LinkCounters::inc(counters().bad_version);
            fail(h, ErrorCode::kBadVersion, error("version", "header version differs from the device's (see hello)"), send);
            return;
        }
        switch (static_cast<MsgType>(h.type)) {
            case MsgType::kGetStatus: {
                GetStatus m;
                if (decode(h, body, m, send)) reply(make_status(), h.seq, send);
                return;
            }
            case MsgType::kGetParams: {
                GetParams m;
                if (decode(h, body, m, send)) get_params(h, m.group, send);
                return;
            }
            case MsgType::kSetParams: set_params(h, body, send); return;
            case MsgType::kArm: {
                Arm m;
                if (!decode(h, body, m, send)) return;
                if (pipeline_.limiter().tripped())
                    return fail(h, ErrorCode::kTripped,
                                in_group("limits", error("trip", trip_reason_name(pipeline_.limiter().trip_reason()))),
                                send);
                pipeline_.arm();
                return ack(h, send);
            }
            case MsgType::kDisarm: {
                Disarm m;
                if (!decode(h, body, m, send)) return;
                pipeline_.disarm();
                return ack(h, send);
            }
            case MsgType::kClearTrip: {
                ClearTrip m;
                if (!decode(h, body, m, send)) return;
                if (pipeline_.armed())
                    return fail(h, ErrorCode::kArmed, in_group("limits", error("trip", "clear the trip only while disarmed")), send);
                mask(true);
                const bool cleared = pipeline_.limiter().clear_trip();
                mask(false);
                if (!cleared)
                    return fail(h, ErrorCode::kTripped,
                                in_group("limits", error("trip", "cannot clear: limits not configured or hard limits invalid")), send);
                return ack(h, send);
            }
            case MsgType::kStartWave: start_wave(h, body, send); return;
            case MsgType::kStopWave: {
                StopWave m;
                if (!decode(h, body, m, send)) return;
                pipeline_.stop_wave();
                return ack(h, send);
            }
            case MsgType::kStreamStart: {
                StreamStart m;
                if (!decode(h, body, m, send)) return;
                if (pipeline_.wave_running())
                    return fail(h, ErrorCode::kBusy, error("stream", "a wave is running: stop it first"), send);
                if (m.prefill > SetpointCapacity)
                    return fail(h, ErrorCode::kInvalidParam, error("prefill", "must be <= the setpoint capacity (hello)"), send);
                // Stop the tick consuming before the FIFO is reset.
                set_stream_state(kStreamIdle);
                fifo_head_ = fifo_tail_ = 0;
                next_block_seq_ = 0;
                underruns_ = consumed_ = 0;
                __atomic_store_n(&drain_, false, __ATOMIC_RELEASE);
                prefill_ = m.prefill;
                set_stream_state(m.prefill == 0 ? kStreamRunning : kStreamPriming);
                // Running with an empty FIFO counts underruns from now on:
                // a client that wants none sends prefill > 0.
                return reply(setpoint_ack(), h.seq, send);
            }
            case MsgType::kSetpoints: setpoints(h, body, send); return;
            case MsgType::kStreamStop: {
                StreamStop m;
                if (!decode(h, body, m, send)) return;
                if (m.drain && stream_state() != kStreamIdle) {
                    __atomic_store_n(&drain_, true, __ATOMIC_RELEASE);
                    if (stream_state() == kStreamPriming) set_stream_state(kStreamRunning);
                } else {
                    set_stream_state(kStreamIdle);
                }
                return ack(h, send);
            }
            case MsgType::kRecorderArm: {
                RecorderArm m;
                if (!decode(h, body, m, send)) return;
                mask(true);
                const bool armed = pipeline_.recorder().arm();
                mask(false);
                if (!armed)
                    return fail(h, ErrorCode::kNotConfigured, in_group("recorder", error("channels", "set the recorder group first")), send);
                log_seq_ = 0;
                log_blocks_ = 0;
                pending_ = 0;
                return ack(h, send);
            }
            case MsgType::kRecorderStop: {
                RecorderStop m;
                if (!decode(h, body, m, send)) return;
                mask(true);
                pipeline_.recorder().stop();
                mask(false);
                return ack(h, send);
            }
            default:
                LinkCounters::inc(counters().unknown_type);
                fail(h, ErrorCode::kUnknownType, error("type", "message type not handled by this device"), send);
                return;
        }
    }

    // Sends at most one log block of recorded frames; returns true if it did.
    // A block is sent when it is full, when the next frame does not follow at
    // the decimation stride (a gap: overrun or the trigger), or when the
    // recorder has stopped and the frames read so far are the last ones.
    template <class Send>
    bool poll_log(Send&& send) {
        RecorderType& rec = pipeline_.recorder();
        if (pending_ < kFramesPerBlock)
            pending_ += rec.read(std::span<typename RecorderType::Frame>(frames_.data() + pending_, kFramesPerBlock - pending_));
        if (pending_ == 0) return false;
        const uint32_t stride = rec.config().decimation;
        std::size_t n = 1;
        while (n < pending_ && frames_[n].tick - frames_[n - 1].tick == stride) ++n;
        const RecorderState st = rec.state();
        const bool stopped = st == RecorderState::kIdle || st == RecorderState::kDone;
        const bool last = stopped && n == pending_ && rec.available() == 0;
        if (n == pending_ && pending_ < kFramesPerBlock && !last) return false;

        LogBlock b;
        b.block_seq = log_seq_;
        b.first_tick = frames_[0].tick;
        b.tick_stride = stride;
        b.recorder_overruns = rec.overruns();
        b.channel_count = static_cast<uint8_t>(RecChannels);
        b.format = kFloat ? SampleFormat::kFloat32 : SampleFormat::kQ31;
        b.frame_count = static_cast<uint8_t>(n);
        b.flags = (last && st == RecorderState::kDone) ? LogBlock::kFlagLast : 0;
        for (std::size_t c = 0; c < RecChannels; ++c) b.channels[c] = rec.config().channels[c];
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t c = 0; c < RecChannels; ++c) b.samples[i * RecChannels + c] = sample_bits(frames_[i].value[c]);
        const std::size_t len = encode_message(b, 0, tx_);
        if (len == 0) return false;  // cannot happen: a full block fits kMaxPayload
        send(std::span<const uint8_t>(tx_.data(), len));
        ++log_seq_;
        LinkCounters::inc(log_blocks_);
        for (std::size_t i = n; i < pending_; ++i) frames_[i - n] = frames_[i];
        pending_ -= n;
        return true;
    }

    // Tick timing and board faults, measured by the firmware.
    void set_tick_stats(const TickStats& s) { tick_stats_ = s; }

    LinkCounters& counters() { return decoder_.counters(); }
    const LinkCounters& counters() const { return decoder_.counters(); }
    FrameDecoder& decoder() { return decoder_; }
    PipelineType& pipeline() { return pipeline_; }

    // ---- tick -----------------------------------------------------------------

    // Feeds the next streamed setpoint to the pipeline. Call it once per tick,
    // right before Pipeline::begin_tick() (or tick()). Bounded time, never fails.
    void on_tick() {
        const uint8_t st = stream_state();
        if (st != kStreamRunning) return;
        const uint32_t head = __atomic_load_n(&fifo_head_, __ATOMIC_ACQUIRE);
        const uint32_t tail = fifo_tail_;
        if (head != tail) {
            pipeline_.set_setpoint(fifo_[tail & kFifoMask]);
            __atomic_store_n(&fifo_tail_, tail + 1u, __ATOMIC_RELEASE);
            __atomic_store_n(&consumed_, consumed_ + 1u, __ATOMIC_RELAXED);
        } else if (__atomic_load_n(&drain_, __ATOMIC_ACQUIRE)) {
            set_stream_state(kStreamIdle);  // end of a drained stream: the setpoint holds
        } else {
            // The setpoint holds its last value; counted, never silent.
            const uint32_t u = __atomic_load_n(&underruns_, __ATOMIC_RELAXED);
            if (u != 0xffffffffu) __atomic_store_n(&underruns_, u + 1u, __ATOMIC_RELAXED);
        }
    }

    // ---- state, for host tests and the firmware -------------------------------

    bool streaming() const { return stream_state() != kStreamIdle; }
    uint32_t setpoint_underruns() const { return __atomic_load_n(&underruns_, __ATOMIC_RELAXED); }
    std::size_t setpoint_free() const {
        return SetpointCapacity - (fifo_head_ - __atomic_load_n(&fifo_tail_, __ATOMIC_ACQUIRE));
    }
    // The parameters a GetParams returns: the newest accepted set.
    const PipelineParams& params() const { return pipeline_.swap_pending() ? staged_ : pipeline_.params(); }
    const TrajectoryParams& trajectory() const { return wave_; }

    HelloReply make_hello() const {
        HelloReply r;
        r.protocol_version = kProtocolVersion;
        set_text(r.board, info_.board);
        set_text(r.firmware_version, info_.firmware_version);
        set_text(r.serial, info_.serial);
        const PipelineSetup& s = pipeline_.setup();
        r.loop_rate_Hz = s.rate_Hz;
        r.capabilities = (kFloat ? cap::kFloat : cap::kQ31) | cap::kDahl | cap::kRepetitive | cap::kSetpointStream |
                         cap::kRecorder | cap::kWaveTable;
        r.sample_format = kFloat ? SampleFormat::kFloat32 : SampleFormat::kQ31;
        r.hard_u_min_V = s.hard.u_min_V;
        r.hard_u_max_V = s.hard.u_max_V;
        r.hard_slew_max_V_per_s = s.hard.slew_max_V_per_s;
        r.position_full_scale_um = s.position.full_scale;
        r.voltage_full_scale_V = s.voltage.full_scale;
        r.setpoint_capacity = static_cast<uint16_t>(SetpointCapacity);
        r.recorder_channels = static_cast<uint8_t>(RecChannels);
        r.recorder_capacity = static_cast<uint32_t>(RecCapacity);
        r.rc_capacity = static_cast<uint32_t>(RcCapacity);
        return r;
    }

    StatusReply make_status() const {
        StatusReply r;
        const auto& lim = pipeline_.limiter();
        r.armed = pipeline_.armed();
        r.tripped = lim.tripped();
        r.trip_reason = lim.trip_reason();
        r.wave_running = pipeline_.wave_running();
        r.streaming = streaming();
        r.swap_pending = pipeline_.swap_pending();
        r.recorder_state = pipeline_.recorder().state();
        r.tick_count = pipeline_.tick_count();
        r.swaps = pipeline_.swaps();
        r.tick = tick_stats_;
        r.setpoint_underruns = setpoint_underruns();
        r.setpoint_free = static_cast<uint16_t>(setpoint_free());
        r.setpoint_next_seq = next_block_seq_;
        r.recorder_overruns = pipeline_.recorder().overruns();
        r.log_blocks = log_blocks_;
        r.link = counters();
        const auto& last = pipeline_.last();
        const PipelineSetup& s = pipeline_.setup();
        r.r_um = s.position.to_physical(last.r);
        r.y_um = s.position.to_physical(last.y);
        r.u_V = s.voltage.to_physical(last.u);
        uint32_t f = 0;
        if (lim.trip_reason() == TripReason::kInvalidHardLimits) f |= fault::kHardLimitsInvalid;
        if (tick_stats_.overruns != 0) f |= fault::kTickOverrun;
        if (r.setpoint_underruns != 0) f |= fault::kSetpointUnderrun;
        if (r.recorder_overruns != 0) f |= fault::kRecorderOverrun;
        if (r.link.dropped() != 0) f |= fault::kLinkErrors;
        f |= tick_stats_.board_faults << 8;
        r.faults = f;
        return r;
    }

private:
    enum : uint8_t { kStreamIdle = 0, kStreamPriming = 1, kStreamRunning = 2 };
    static constexpr uint32_t kFifoMask = static_cast<uint32_t>(SetpointCapacity - 1);

    uint8_t stream_state() const { return __atomic_load_n(&stream_state_, __ATOMIC_ACQUIRE); }
    void set_stream_state(uint8_t s) { __atomic_store_n(&stream_state_, s, __ATOMIC_RELEASE); }

    void mask(bool m) const {
        if (hooks_.mask_tick != nullptr) hooks_.mask_tick(m);
    }

    static uint32_t sample_bits(T v) {
        if constexpr (kFloat) return std::bit_cast<uint32_t>(v); else return static_cast<uint32_t>(v.raw());
    }

    template <class M, class Send>
    void reply(const M& m, uint16_t seq, Send& send) {
        const std::size_t len = encode_message(m, seq, tx_);
        if (len != 0) send(std::span<const uint8_t>(tx_.data(), len));
    }
    template <class Send>
    void ack(const FrameHeader& h, Send& send) {
        Ack a;
        a.request_type = h.type;
        reply(a, h.seq, send);
    }
    template <class Send>
    void fail(const FrameHeader& h, ErrorCode code, const Status& s, Send& send) {
        LinkCounters::inc(counters().error_replies);
        reply(make_error(h.type, code, s), h.seq, send);
    }

    // Decodes a request body; on a malformed body counts it and replies.
    template <class M, class Send>
    bool decode(const FrameHeader& h, std::span<const uint8_t> body, M& m, Send& send) {
        switch (decode_body(body, m)) {
            case DecodeResult::kOk: return true;
            case DecodeResult::kTruncated:
                LinkCounters::inc(counters().truncated);
                fail(h, ErrorCode::kMalformed, error("body", "shorter than the message layout"), send);
                return false;
            case DecodeResult::kTooLong:
                LinkCounters::inc(counters().bad_length);
                fail(h, ErrorCode::kMalformed, error("body", "longer than the message layout"), send);
                return false;
            case DecodeResult::kBadValue:
                LinkCounters::inc(counters().bad_value);
                fail(h, ErrorCode::kMalformed, error("body", "boolean not 0/1, count beyond its array, or wrong group id"), send);
                return false;
        }
        return false;
    }

    // StartWave: every check first, then the wave, the arms and the stage
    // restart in one masked section, so the tick after it is the wave's
    // tick 0 for all of them.
    template <class Send>
    void start_wave(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        StartWave m;
        if (!decode(h, body, m, send)) return;
        const uint8_t f = m.flags;
        if ((f & ~StartWave::kKnownFlags) != 0) {
            LinkCounters::inc(counters().bad_value);
            return fail(h, ErrorCode::kMalformed,
                        error("flags", "unknown bits: only bit0 arm loop, bit1 arm recorder, bit2 restart stage"), send);
        }
        if ((f & StartWave::kRestartStage) != 0 && hooks_.restart_stage == nullptr)
            return fail(h, ErrorCode::kUnsupported, error("flags", "restart stage (bit2): this device has no emulated stage"), send);
        if (!wave_set_)
            return fail(h, ErrorCode::kNotConfigured, in_group("trajectory", error("waveform", "set the trajectory group first")), send);
        if (stream_state() != kStreamIdle)
            return fail(h, ErrorCode::kBusy, in_group("trajectory", error("waveform", "a setpoint stream is running: stop it first")), send);
        if (pipeline_.wave_running())
            return fail(h, ErrorCode::kBusy, in_group("trajectory", error("waveform", "a wave is running: stop it first")), send);
        if ((f & StartWave::kArmLoop) != 0) {
            if (pipeline_.limiter().tripped())
                return fail(h, ErrorCode::kTripped,
                            in_group("limits", error("trip", trip_reason_name(pipeline_.limiter().trip_reason()))), send);
            // Armed already, the controller's states would not restart from rest.
            if (pipeline_.armed())
                return fail(h, ErrorCode::kArmed, error("flags", "arm loop (bit0): the loop is armed; disarm first"), send);
        }
        if ((f & StartWave::kArmRecorder) != 0 && !pipeline_.recorder().configured())
            return fail(h, ErrorCode::kNotConfigured, in_group("recorder", error("channels", "set the recorder group first")), send);
        mask(true);
        if ((f & StartWave::kRestartStage) != 0 && !hooks_.restart_stage()) {
            mask(false);
            return fail(h, ErrorCode::kUnsupported, error("flags", "restart stage (bit2): the stage could not restart"), send);
        }
        if (const Status s = pipeline_.start_wave(trajectory_config(wave_, wave_table_)); !s.ok()) {
            mask(false);
            return fail(h, ErrorCode::kInvalidParam, s, send);
        }
        if ((f & StartWave::kArmLoop) != 0) pipeline_.arm();
        if ((f & StartWave::kArmRecorder) != 0) (void)pipeline_.recorder().arm();  // configured: cannot fail
        mask(false);
        if ((f & StartWave::kArmRecorder) != 0) {
            log_seq_ = 0;
            log_blocks_ = 0;
            pending_ = 0;
        }
        ack(h, send);
    }

    // ---- parameter groups -----------------------------------------------------

    static FeedforwardParams feedforward_of(const PipelineParams& p) { return {p.feedforward, p.pi, p.dahl}; }
    static FeedbackParams feedback_of(const PipelineParams& p) { return {p.feedback, p.sos_count, p.sos, p.pid}; }
    static RepetitiveParams rc_of(const PipelineParams& p) { return {p.rc_enabled, p.rc}; }

    RecorderParams recorder_params() const {
        const auto& c = pipeline_.recorder().config();
        RecorderParams r;
        r.channel_count = pipeline_.recorder().configured() ? static_cast<uint8_t>(RecChannels) : 0;
        for (std::size_t i = 0; i < RecChannels; ++i) r.channels[i] = c.channels[i];
        r.decimation = c.decimation;
        r.mode = c.mode;
        r.trigger = c.trigger;
        r.trigger_signal = c.trigger_signal;
        r.trigger_level = c.trigger_level;
        r.pre_trigger = c.pre_trigger;
        r.length = c.length;
        return r;
    }

    template <class Send>
    void get_params(const FrameHeader& h, ParamGroup g, Send& send) {
        const PipelineParams& p = params();
        switch (g) {
            case ParamGroup::kFeedforward: return reply(ParamsReply<FeedforwardParams>{feedforward_of(p)}, h.seq, send);
            case ParamGroup::kFeedback: return reply(ParamsReply<FeedbackParams>{feedback_of(p)}, h.seq, send);
            case ParamGroup::kRepetitive: return reply(ParamsReply<RepetitiveParams>{rc_of(p)}, h.seq, send);
            case ParamGroup::kLimits: return reply(ParamsReply<LimitsParams>{LimitsParams{p.limits}}, h.seq, send);
            case ParamGroup::kTrajectory: return reply(ParamsReply<TrajectoryParams>{wave_}, h.seq, send);
            case ParamGroup::kRecorder: return reply(ParamsReply<RecorderParams>{recorder_params()}, h.seq, send);
        }
        fail(h, ErrorCode::kBadGroup, error("group", "unknown parameter group"), send);
    }

    template <class Send>
    void set_params(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        switch (static_cast<ParamGroup>(body_group(body))) {
            case ParamGroup::kFeedforward: return set_group<FeedforwardParams>(h, body, send);
            case ParamGroup::kFeedback: return set_group<FeedbackParams>(h, body, send);
            case ParamGroup::kRepetitive: return set_group<RepetitiveParams>(h, body, send);
            case ParamGroup::kLimits: return set_group<LimitsParams>(h, body, send);
            case ParamGroup::kTrajectory: return set_group<TrajectoryParams>(h, body, send);
            case ParamGroup::kRecorder: return set_group<RecorderParams>(h, body, send);
        }
        LinkCounters::inc(counters().bad_value);
        fail(h, ErrorCode::kBadGroup, error("group", "unknown parameter group"), send);
    }

    template <class G, class Send>
    void set_group(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        SetParams<G> m;
        if (!decode(h, body, m, send)) return;
        const Status s = apply(m.value);
        if (s.ok()) return ack(h, send);
        fail(h, last_code_, s.group == nullptr ? in_group(group_name(G::kGroup), s) : s, send);
    }

    // Stages p; sets last_code_ for an error.
    Status stage(const PipelineParams& p) {
        const Status s = pipeline_.stage(p);
        if (s.ok()) staged_ = p; else last_code_ = ErrorCode::kInvalidParam;
        return s;
    }
    Status busy_or_armed(bool critical_change, const char* field) {
        if (pipeline_.swap_pending()) {
            last_code_ = ErrorCode::kBusy;
            return error("params", "previous parameter set not yet swapped in; retry after one tick");
        }
        if (critical_change && pipeline_.armed()) {
            last_code_ = ErrorCode::kArmed;
            return error(field, "limit-critical: changes only while disarmed");
        }
        return ok_status();
    }
    Status invalid(Status s) {
        last_code_ = ErrorCode::kInvalidParam;
        return s;
    }

    // Every float and double of a group is finite, whether or not the kind in
    // use reads it (a stored NaN would surface when the kind is switched).
    static Status finite(const SosSection& q, const char* field, int index) {
        if (!is_finite(q.b0) || !is_finite(q.b1) || !is_finite(q.b2) || !is_finite(q.a1) || !is_finite(q.a2))
            return error(field, index, "coefficients must be finite");
        return ok_status();
    }

    Status apply(const FeedforwardParams& v) {
        const PipelineParams& cur = pipeline_.params();
        if (v == feedforward_of(cur) && !pipeline_.swap_pending()) return ok_status();
        if (const Status s = busy_or_armed(v.kind != cur.feedforward, "kind"); !s.ok()) return s;
        if (const Status s = piezoloop::validate(v.pi); !s.ok()) return invalid(in_group("pi", s));
        const DahlParams& d = v.dahl;
        if (!is_finite(d.alpha1) || !is_finite(d.alpha2) || !is_finite(d.beta1) || !is_finite(d.beta2) ||
            !is_finite(d.gamma_a) || !is_finite(d.ga))
            return invalid(in_group("dahl", error("params", "must be finite")));
        PipelineParams p = cur;
        p.feedforward = v.kind;
        p.pi = v.pi;
        p.dahl = v.dahl;
        return stage(p);
    }

    Status apply(const FeedbackParams& v) {
        const PipelineParams& cur = pipeline_.params();
        if (v == feedback_of(cur) && !pipeline_.swap_pending()) return ok_status();
        const char* critical = v.kind != cur.feedback ? "kind"
                               : v.sos_count != cur.sos_count ? "sos_count"
                               : !(v.pid.u_min == cur.pid.u_min) ? "u_min"
                               : !(v.pid.u_max == cur.pid.u_max) ? "u_max"
                                                                  : nullptr;
        if (const Status s = busy_or_armed(critical != nullptr, critical); !s.ok())
            return critical != nullptr && last_code_ == ErrorCode::kArmed && (critical[0] == 'u')
                       ? in_group("pid", s) : s;
        for (int i = 0; i < kMaxControllerSections; ++i)
            if (const Status s = finite(v.sos[static_cast<unsigned>(i)], "sections", i); !s.ok()) return invalid(in_group("sos", s));
        const PidConfig& c = v.pid;
        if (!is_finite(c.kp) || !is_finite(c.ki_per_s) || !is_finite(c.kd_s) || !is_finite(c.derivative_cutoff_Hz) ||
            !is_finite(c.u_min) || !is_finite(c.u_max))
            return invalid(in_group("pid", error("params", "must be finite")));
        PipelineParams p = cur;
        p.feedback = v.kind;
        p.sos_count = v.sos_count;
        p.sos = v.sos;
        p.pid = v.pid;
        return stage(p);
    }

    Status apply(const RepetitiveParams& v) {
        const PipelineParams& cur = pipeline_.params();
        if (v == rc_of(cur) && !pipeline_.swap_pending()) return ok_status();
        if (const Status s = busy_or_armed(v.enabled != cur.rc_enabled, "enabled"); !s.ok()) return s;
        if (!is_finite(v.rc.k_rc)) return invalid(error("k_rc", "must be finite"));
        if (const Status s = finite(v.rc.q, "q", -1); !s.ok()) return invalid(s);
        if (v.enabled) {
            // Validate even when the pipeline would not yet (it checks RC
            // only with feedback on), so the error names the RC field.
            // (No scratch RepetitiveController: its delay line would put
            // RcCapacity samples on the main loop's stack.)
            if (const Status s = RepetitiveController<T, RcCapacity>::validate(v.rc); !s.ok()) return invalid(s);
            BiquadCascade<T, 1> q;
            const SignalScale unit{1.0f};
            if (const Status s = q.configure(&v.rc.q, 1, unit, unit); !s.ok()) return invalid(error("q", s.message));
        }
        PipelineParams p = cur;
        p.rc_enabled = v.enabled;
        p.rc = v.rc;
        return stage(p);
    }

    Status apply(const LimitsParams& v) {
        const PipelineParams& cur = pipeline_.params();
        const LimitsConfig& a = v.limits;
        const LimitsConfig& b = cur.limits;
        const char* changed = !(a.u_min_V == b.u_min_V) ? "u_min_V"
                              : !(a.u_max_V == b.u_max_V) ? "u_max_V"
                              : !(a.slew_V_per_s == b.slew_V_per_s) ? "slew_V_per_s"
                              : !(a.saturation_trip_s == b.saturation_trip_s) ? "saturation_trip_s"
                                                                               : nullptr;
        // Limits also configure the limiter, so an unchanged set is staged
        // anyway while nothing has configured it yet.
        if (changed == nullptr && pipeline_.limiter().configured() && !pipeline_.swap_pending()) return ok_status();
        if (const Status s = busy_or_armed(changed != nullptr, changed); !s.ok()) return s;
        PipelineParams p = cur;
        p.limits = v.limits;
        return stage(p);
    }

    Status apply(const TrajectoryParams& v) {
        // Validated by a scratch generator at the loop rate; stored, and run by StartWave.
        TrajectoryGenerator<T, kMaxWaveTable> scratch(pipeline_.setup().position);
        if (const Status s = scratch.configure(trajectory_config(v, v.table)); !s.ok()) return invalid(s);
        wave_ = v;
        wave_table_ = v.table;
        wave_set_ = true;
        return ok_status();
    }

    Status apply(const RecorderParams& v) {
        if (v.channel_count != RecChannels) {
            last_code_ = ErrorCode::kUnsupported;
            return error("channel_count", "must equal the device's recorder channel count (hello)");
        }
        typename RecorderType::Config c{};
        for (std::size_t i = 0; i < RecChannels; ++i) c.channels[i] = v.channels[i];
        c.decimation = v.decimation;
        c.mode = v.mode;
        c.trigger = v.trigger;
        c.trigger_signal = v.trigger_signal;
        c.trigger_level = v.trigger_level;
        // r, y, e are positions; u, u_ff, u_fb, u_rc voltages.
        c.trigger_scale = v.trigger_signal <= signal_index(SignalId::kE) ? pipeline_.setup().position
                                                                          : pipeline_.setup().voltage;
        c.pre_trigger = v.pre_trigger;
        c.length = v.length;
        mask(true);
        const Status s = pipeline_.recorder().configure(c);
        mask(false);
        if (!s.ok()) return invalid(s);
        pending_ = 0;
        return ok_status();
    }

    TrajectoryConfig trajectory_config(const TrajectoryParams& v, const std::array<float, kMaxWaveTable>& table) const {
        TrajectoryConfig c;
        c.waveform = v.waveform;
        c.amplitude_um = v.amplitude_um;
        c.offset_um = v.offset_um;
        c.frequency_Hz = v.frequency_Hz;
        c.sample_rate_Hz = pipeline_.setup().rate_Hz;
        c.cycles = v.cycles;
        c.start_phase_cycles = v.start_phase_cycles;
        c.return_fraction = v.return_fraction;
        c.duty = v.duty;
        c.table = std::span<const float>(table.data(), v.table_count <= kMaxWaveTable ? v.table_count : 0);
        return c;
    }

    // ---- setpoint stream ------------------------------------------------------

    SetpointAck setpoint_ack() const {
        SetpointAck a;
        a.next_block_seq = next_block_seq_;
        a.free = static_cast<uint16_t>(setpoint_free());
        a.capacity = static_cast<uint16_t>(SetpointCapacity);
        a.underruns = setpoint_underruns();
        a.consumed = __atomic_load_n(&consumed_, __ATOMIC_RELAXED);
        return a;
    }

    template <class Send>
    void setpoints(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        SetpointBlock m;
        if (!decode(h, body, m, send)) return;
        if (stream_state() == kStreamIdle || drain_)
            return fail(h, ErrorCode::kNotConfigured, error("stream", "no stream open: send StreamStart first"), send);
        if (m.block_seq != next_block_seq_)
            return fail(h, ErrorCode::kSequence, error("block_seq", "out of sequence: block dropped (status: setpoint_next_seq)"), send);
        for (std::size_t i = 0; i < m.count; ++i) {
            const float x = m.setpoint_um[i];
            if (!is_finite(x) || x < -1.0e6f || x > 1.0e6f)
                return fail(h, ErrorCode::kInvalidParam, error("setpoint_um", static_cast<int>(i), "must be finite and within +-1e6 um"), send);
        }
        if (m.count > setpoint_free())
            return fail(h, ErrorCode::kNoSpace, error("count", "more setpoints than free FIFO slots: block dropped"), send);
        const SignalScale pos = pipeline_.setup().position;
        uint32_t head = fifo_head_;
        for (std::size_t i = 0; i < m.count; ++i) fifo_[(head++) & kFifoMask] = pos.to_sample<T>(m.setpoint_um[i]);
        __atomic_store_n(&fifo_head_, head, __ATOMIC_RELEASE);
        ++next_block_seq_;
        if (stream_state() == kStreamPriming && SetpointCapacity - setpoint_free() >= prefill_)
            set_stream_state(kStreamRunning);
        reply(setpoint_ack(), h.seq, send);
    }

    PipelineType& pipeline_;
    DeviceInfo info_;
    DeviceHooks hooks_;
    FrameDecoder decoder_{};
    std::array<uint8_t, kMaxFrameSize> tx_{};
    ErrorCode last_code_ = ErrorCode::kInvalidParam;
    PipelineParams staged_{};
    TickStats tick_stats_{};

    TrajectoryParams wave_{};
    std::array<float, kMaxWaveTable> wave_table_{};
    bool wave_set_ = false;

    // Setpoint FIFO: the main loop writes fifo_head_, the tick fifo_tail_.
    std::array<T, SetpointCapacity> fifo_{};
    uint32_t fifo_head_ = 0;
    uint32_t fifo_tail_ = 0;
    uint8_t stream_state_ = kStreamIdle;
    bool drain_ = false;
    uint16_t prefill_ = 0;
    uint32_t next_block_seq_ = 0;
    uint32_t underruns_ = 0;  // tick
    uint32_t consumed_ = 0;   // tick

    // Log stream.
    std::array<typename RecorderType::Frame, kFramesPerBlock> frames_{};
    std::size_t pending_ = 0;
    uint32_t log_seq_ = 0;
    uint32_t log_blocks_ = 0;
};

}  // namespace piezoloop::link
