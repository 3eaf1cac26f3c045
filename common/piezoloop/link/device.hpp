// Device side of the link: decodes requests from the byte stream, answers
// them, and applies them to a Pipeline<T> (one axis), or to the N axes of a
// MultiAxisPipeline<T, N> (MultiAxis = true). No heap; the same code runs in
// the firmware main loop and in host tests. The device dispatches; what it
// does with an axis's parameter groups is link/param_policy.hpp, with the
// board's (recorder, link, matrices) link/board_policy.hpp, the setpoint
// FIFO link/setpoint_stream.hpp, the recorder's blocks link/log_stream.hpp.
//
// Axes: the axis-scoped requests (GetParams / SetParams of an axis's group,
// StartWave / StopWave, StartExcitation / StopExcitation, StreamStart) name
// their axis; one at or beyond the axis count is refused (invalid_param,
// field "axis") and changes nothing. Arm, Disarm and ClearTrip act on every
// axis at one tick boundary; the recorder is the board's and records
// (axis, signal) channels; the setpoint stream feeds one axis at a time.
//
// Contexts (as in the firmware):
//   main loop: receive(), poll_log(), set_tick_stats()   -- one thread
//   tick:      on_tick() just before Pipeline::begin_tick() or tick() -- the timer interrupt
// The recorder and the limiter trip are touched from the main loop only
// inside the mask_tick hook (the firmware masks the tick interrupt there).
// Clear-trip is refused while armed (as are limit-critical parameters).
//
// Storage (storage/param_storage.hpp, given in DeviceHooks): Save stores the
// set GetParams reports once it passes the check Load makes (check_set),
// Load validates and applies the stored set as a whole (check_set, then
// ParamPolicy::set_all), Forget erases it; boot_from_storage() is Load at
// boot, and its outcome is the status' storage block. All three
// requests are refused while armed: Load replaces limit-critical groups,
// and Save / Forget block the main loop (and with it the link and the
// client watchdog) for as long as the medium takes -- a flash sector erase
// takes seconds.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>
#include <utility>

#include "piezoloop/axes/multi_axis_pipeline.hpp"
#include "piezoloop/link/board_policy.hpp"
#include "piezoloop/link/device_scan.hpp"
#include "piezoloop/link/framing.hpp"
#include "piezoloop/link/log_stream.hpp"
#include "piezoloop/link/messages.hpp"
#include "piezoloop/link/param_policy.hpp"
#include "piezoloop/link/setpoint_stream.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/storage/param_storage.hpp"
#include "piezoloop/storage/stored_params.hpp"

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
    // Where the parameter set is stored (Save / Load / Forget, the load at
    // boot). Null: the board has no storage; the requests are refused
    // (ErrorCode::kUnsupported) and the hello reply lacks cap::kStorage.
    storage::ParamStorage* storage = nullptr;
};

// BoardRecChannels: the channels of a MultiAxisPipeline's board recorder
// (the recorder a device of axes streams), RecChannels each axis's own.
template <class T, int RcCapacity = 1024, std::size_t RecChannels = 4, std::size_t RecCapacity = 1024,
          std::size_t SetpointCapacity = 1024, std::size_t ExcCapacity = 1024, int N = 1, bool MultiAxis = (N > 1),
          std::size_t BoardRecChannels = RecChannels>
class Device {
    static_assert(is_sample_type_v<T>, "Device<T>: T is float or Q31");
    static_assert(N >= 1 && N <= kMaxAxes, "Device: 1 to 3 axes");
    static_assert(MultiAxis || N == 1, "Device: more than one axis needs a MultiAxisPipeline");
    static constexpr bool kFloat = std::is_same_v<T, float>;
    // A board of two or three axes runs scans (StartScan).
    static constexpr bool kScans = MultiAxis && N >= 2;
    struct NoScan {
        template <class P>
        explicit constexpr NoScan(P&) {}
    };

public:
    static constexpr int kAxes = N;
    // An axis's pipeline (the single one, or each of the multi-axis pipeline's).
    using PipelineType = Pipeline<T, RcCapacity, RecChannels, RecCapacity, ExcCapacity>;
    using MultiType = MultiAxisPipeline<T, N, RcCapacity, RecChannels, RecCapacity, ExcCapacity, BoardRecChannels>;
    using RecorderType =
        std::conditional_t<MultiAxis, typename MultiType::RecorderType, typename PipelineType::RecorderType>;
    static constexpr std::size_t kRecorderChannels = RecorderType::kChannels;
    using LogStreamType = LogStream<T, RecorderType, kRecorderChannels>;
    static constexpr std::size_t kFramesPerBlock = LogStreamType::kFramesPerBlock;

    Device(PipelineType& pipeline, const DeviceInfo& info = {}, const DeviceHooks& hooks = {})
        requires(!MultiAxis)
        : axes_{&pipeline},
          multi_(nullptr),
          recorder_(pipeline.recorder()),
          info_(info),
          hooks_(hooks),
          policies_{ParamPolicy<PipelineType>(pipeline)},
          board_(pipeline.recorder(), {&pipeline.setup()}, nullptr, hooks.mask_tick),
          scan_(pipeline) {}

    Device(MultiType& multi, const DeviceInfo& info = {}, const DeviceHooks& hooks = {})
        requires(MultiAxis)
        : Device(multi, info, hooks, std::make_index_sequence<N>{}) {}

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
        last_frame_tick_ = axes_[0]->tick_count();  // the client is alive
        if (h.type == static_cast<uint8_t>(MsgType::kHello)) {
            // A client opens its session with Hello: what the previous
            // session's client started is lost with it (see client loss).
            if (client_bound_ && board_.client_timeout_ticks() != 0 && bound_run_active()) lose_client();
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
                if (decode(h, body, m, send)) get_params(h, m, send);
                return;
            }
            case MsgType::kSetParams: set_params(h, body, send); return;
            case MsgType::kArm: {
                Arm m;
                if (!decode(h, body, m, send)) return;
                if (const int a = tripped_axis(); a >= 0) return fail(h, ErrorCode::kTripped, trip_status(a), send);
                arm_all();
                return ack(h, send);
            }
            case MsgType::kDisarm: {
                Disarm m;
                if (!decode(h, body, m, send)) return;
                disarm_all();
                return ack(h, send);
            }
            case MsgType::kClearTrip: {
                ClearTrip m;
                if (!decode(h, body, m, send)) return;
                if (any_armed())
                    return fail(h, ErrorCode::kArmed, in_group("limits", error("trip", "clear the trip only while disarmed")), send);
                int failed = -1;
                mask(true);
                for (int a = 0; a < N; ++a)
                    if (axes_[a]->limiter().tripped() && !axes_[a]->limiter().clear_trip() && failed < 0) failed = a;
                if constexpr (MultiAxis) multi_->clear_channel_trips();
                mask(false);
                if (failed >= 0)
                    return fail(h, ErrorCode::kTripped,
                                in_group("limits", error("trip", N > 1 ? failed : -1,
                                                         "cannot clear: limits not configured or hard limits invalid")),
                                send);
                return ack(h, send);
            }
            case MsgType::kStartWave: start_wave(h, body, send); return;
            case MsgType::kStartExcitation: start_excitation(h, body, send); return;
            case MsgType::kStartScan: start_scan(h, body, send); return;
            case MsgType::kStopExcitation: {
                StopExcitation m;
                if (!decode(h, body, m, send) || !check_axis(h, m.axis, send)) return;
                axes_[m.axis]->stop_excitation();
                return ack(h, send);
            }
            case MsgType::kStopWave: {
                StopWave m;
                if (!decode(h, body, m, send) || !check_axis(h, m.axis, send)) return;
                axes_[m.axis]->stop_wave();
                if constexpr (kScans) scan_.request_stop();  // a scan moves every axis
                return ack(h, send);
            }
            case MsgType::kStreamStart: {
                StreamStart m;
                if (!decode(h, body, m, send) || !check_axis(h, m.axis, send)) return;
                if (axes_[m.axis]->wave_running())
                    return fail(h, ErrorCode::kBusy, error("stream", "a wave is running: stop it first"), send);
                if (scan_active())
                    return fail(h, ErrorCode::kBusy, error("stream", "a scan is running: stop it first"), send);
                if (stream_.open() && m.axis != stream_axis_)
                    return fail(h, ErrorCode::kBusy, error("stream", "a stream to another axis is open: stop it first"),
                                send);
                if (m.prefill > SetpointCapacity)
                    return fail(h, ErrorCode::kInvalidParam, error("prefill", "must be <= the setpoint capacity (hello)"), send);
                // Running with an empty FIFO counts underruns from now on:
                // a client that wants none sends prefill > 0.
                stream_axis_ = m.axis;
                stream_.start(m.prefill);
                bind_client(true);
                return reply(stream_.ack(), h.seq, send);
            }
            case MsgType::kSetpoints: setpoints(h, body, send); return;
            case MsgType::kStreamStop: {
                StreamStop m;
                if (!decode(h, body, m, send)) return;
                stream_.stop(m.drain);
                return ack(h, send);
            }
            case MsgType::kRecorderArm: {
                RecorderArm m;
                if (!decode(h, body, m, send)) return;
                mask(true);
                const bool armed = recorder_.arm();
                mask(false);
                if (!armed)
                    return fail(h, ErrorCode::kNotConfigured, in_group("recorder", error("channels", "set the recorder group first")), send);
                log_.restart();
                return ack(h, send);
            }
            case MsgType::kSave:
            case MsgType::kLoad:
            case MsgType::kForget: storage_request(h, body, send); return;
            case MsgType::kRecorderStop: {
                RecorderStop m;
                if (!decode(h, body, m, send)) return;
                mask(true);
                recorder_.stop();
                mask(false);
                return ack(h, send);
            }
            default:
                LinkCounters::inc(counters().unknown_type);
                fail(h, ErrorCode::kUnknownType, error("type", "message type not handled by this device"), send);
                return;
        }
    }

    // Sends at most one log block of recorded frames; returns true if it did
    // (link/log_stream.hpp says when a block is sent).
    // Also the main loop's regular call: it watches for a lost client.
    template <class Send>
    bool poll_log(Send&& send) {
        watch_client();
        return log_.poll(recorder_, std::span<uint8_t>(tx_), send);
    }

    // The stored set at boot: validated and applied as Load does (the loop
    // stays disarmed), or ignored; the outcome and why are reported in the
    // status. Main loop, before the first client; the tick may be stopped
    // (the set is then swapped in at its first tick).
    StorageState boot_from_storage() {
        if (hooks_.storage == nullptr) {
            note_boot({StorageState::kAbsent, ok_status(), ErrorCode::kNone});
        } else {
            note_boot(load_stored());
        }
        return boot_state_;
    }
    StorageState boot_storage_state() const { return boot_state_; }

    // Tick timing and board faults, measured by the firmware.
    void set_tick_stats(const TickStats& s) { tick_stats_ = s; }

    LinkCounters& counters() { return decoder_.counters(); }
    const LinkCounters& counters() const { return decoder_.counters(); }
    FrameDecoder& decoder() { return decoder_; }
    // Axis 0's pipeline (a single-axis device's only one), and axis i's.
    PipelineType& pipeline() { return *axes_[0]; }
    PipelineType& axis(int i) { return *axes_[i]; }
    RecorderType& recorder() { return recorder_; }

    // ---- tick -----------------------------------------------------------------

    // Feeds the next streamed setpoint to the pipeline. Call it once per tick,
    // right before Pipeline::begin_tick() (or tick()). Bounded time, never fails.
    void on_tick() {
        T setpoint;
        if (stream_.on_tick(setpoint)) axes_[stream_axis_]->set_setpoint(setpoint);
        if constexpr (kScans) scan_.on_tick();
    }

    // ---- state, for host tests and the firmware -------------------------------

    bool streaming() const { return stream_.open(); }
    uint32_t setpoint_underruns() const { return stream_.underruns(); }
    std::size_t setpoint_free() const { return stream_.free_slots(); }
    // The parameters a GetParams returns: the newest accepted set.
    const PipelineParams& params(int axis = 0) const { return policies_[axis].params(); }
    const TrajectoryParams& trajectory(int axis = 0) const { return policies_[axis].wave(); }

    HelloReply make_hello() const {
        HelloReply r;
        r.protocol_version = kProtocolVersion;
        set_text(r.board, info_.board);
        set_text(r.firmware_version, info_.firmware_version);
        set_text(r.serial, info_.serial);
        const PipelineSetup& s = axes_[0]->setup();
        r.loop_rate_Hz = s.rate_Hz;
        r.capabilities = (kFloat ? cap::kFloat : cap::kQ31) | cap::kDahl | cap::kRepetitive | cap::kSetpointStream |
                         cap::kRecorder | cap::kWaveTable | cap::kExcitation |
                         (hooks_.storage != nullptr ? cap::kStorage : 0u) | (MultiAxis ? cap::kAxisMatrices : 0u) |
                         (kScans ? cap::kScan : 0u);
        r.sample_format = kFloat ? SampleFormat::kFloat32 : SampleFormat::kQ31;
        r.hard_u_min_V = s.hard.u_min_V;
        r.hard_u_max_V = s.hard.u_max_V;
        r.hard_slew_max_V_per_s = s.hard.slew_max_V_per_s;
        r.position_full_scale_um = s.position.full_scale;
        r.voltage_full_scale_V = s.voltage.full_scale;
        r.setpoint_capacity = static_cast<uint16_t>(SetpointCapacity);
        r.recorder_channels = static_cast<uint8_t>(kRecorderChannels);
        r.recorder_capacity = static_cast<uint32_t>(RecCapacity);
        r.rc_capacity = static_cast<uint32_t>(RcCapacity);
        r.excitation_capacity = static_cast<uint32_t>(ExcCapacity);
        r.axis_count = static_cast<uint8_t>(N);
        for (int a = 0; a < N; ++a) {
            const PipelineSetup& x = axes_[a]->setup();
            r.axis_hard_u_min_V[a] = x.hard.u_min_V;
            r.axis_hard_u_max_V[a] = x.hard.u_max_V;
            r.axis_hard_slew_max_V_per_s[a] = x.hard.slew_max_V_per_s;
            r.axis_position_full_scale_um[a] = x.position.full_scale;
            r.axis_voltage_full_scale_V[a] = x.voltage.full_scale;
        }
        return r;
    }

    StatusReply make_status() const {
        StatusReply r;
        const PipelineType& p0 = *axes_[0];
        const auto& lim = p0.limiter();
        r.armed = p0.armed();
        r.tripped = lim.tripped();
        r.trip_reason = lim.trip_reason();
        r.wave_running = p0.wave_running();
        r.streaming = streaming();
        r.swap_pending = any_swap_pending();
        r.recorder_state = recorder_.state();
        r.tick_count = p0.tick_count();
        r.swaps = p0.swaps();
        r.tick = tick_stats_;
        r.setpoint_underruns = setpoint_underruns();
        r.setpoint_free = static_cast<uint16_t>(setpoint_free());
        r.setpoint_next_seq = stream_.next_block_seq();
        r.recorder_overruns = recorder_.overruns();
        r.log_blocks = log_.blocks_sent();
        r.link = counters();
        uint32_t f = 0;
        r.axis_count = static_cast<uint8_t>(N);
        for (int a = 0; a < N; ++a) {
            const PipelineType& p = *axes_[a];
            const auto& last = p.last();
            const PipelineSetup& s = p.setup();
            r.axis_armed[a] = p.armed();
            r.axis_tripped[a] = p.limiter().tripped();
            r.axis_trip_reason[a] = static_cast<uint8_t>(p.limiter().trip_reason());
            r.axis_wave_running[a] = p.wave_running();
            r.axis_excitation_running[a] = p.excitation_running();
            r.axis_swaps[a] = p.swaps();
            r.axis_excitation_ticks[a] = p.excitation_ticks();
            r.axis_excitation_clipped[a] = p.excitation_clipped_samples();
            r.axis_r_um[a] = s.position.to_physical(last.r);
            r.axis_y_um[a] = s.position.to_physical(last.y);
            r.axis_u_V[a] = s.voltage.to_physical(last.u);
            if constexpr (MultiAxis) {
                r.channel_u_V[a] = s.voltage.to_physical(multi_->channel_commands()[a]);
                r.channel_clamped[a] = multi_->channel_clamped_samples(a);
                r.channel_slew_limited[a] = multi_->channel_slew_limited_samples(a);
            } else {
                r.channel_u_V[a] = r.axis_u_V[a];  // no channel stage: the channel is the axis
            }
            if (p.limiter().trip_reason() == TripReason::kInvalidHardLimits) f |= fault::kHardLimitsInvalid;
        }
        if constexpr (kScans) {
            r.scan_state = static_cast<uint8_t>(scan_.state());
            r.scan_approach_ticks = scan_.approach_ticks();
            r.scan_ticks = scan_.ticks();
            r.scan_frames_completed = scan_.frames_completed();
        }
        r.r_um = r.axis_r_um[0];
        r.y_um = r.axis_y_um[0];
        r.u_V = r.axis_u_V[0];
        r.excitation_running = p0.excitation_running();
        r.excitation_ticks = p0.excitation_ticks();
        r.excitation_clipped = p0.excitation_clipped_samples();
        if (tick_stats_.overruns != 0) f |= fault::kTickOverrun;
        if (r.setpoint_underruns != 0) f |= fault::kSetpointUnderrun;
        if (r.recorder_overruns != 0) f |= fault::kRecorderOverrun;
        if (r.link.dropped() != 0) f |= fault::kLinkErrors;
        if (client_lost_) f |= fault::kClientLost;
        f |= tick_stats_.board_faults << 8;
        r.faults = f;
        r.storage = boot_state_;
        r.storage_group = boot_why_.group;
        r.storage_field = boot_why_.field;
        r.storage_index = boot_why_.index;
        r.storage_message = boot_why_.message;
        return r;
    }

private:
    template <std::size_t... I>
    Device(MultiType& multi, const DeviceInfo& info, const DeviceHooks& hooks, std::index_sequence<I...>)
        : axes_{&multi.axis(static_cast<int>(I))...},
          multi_(&multi),
          recorder_(multi.recorder()),
          info_(info),
          hooks_(hooks),
          policies_{ParamPolicy<PipelineType>(multi.axis(static_cast<int>(I)))...},
          board_(multi.recorder(), {&multi.axis(static_cast<int>(I)).setup()...}, &multi, hooks.mask_tick),
          scan_(multi) {}

    // ---- every axis -------------------------------------------------------------

    bool any_armed() const {
        for (const PipelineType* p : axes_)
            if (p->armed()) return true;
        return false;
    }
    bool any_swap_pending() const {
        for (const PipelineType* p : axes_)
            if (p->swap_pending()) return true;
        return false;
    }
    bool any_running() const {
        for (const PipelineType* p : axes_)
            if (p->wave_running() || p->excitation_running()) return true;
        return scan_active();
    }
    bool scan_active() const {
        if constexpr (kScans) return scan_.active();
        else return false;
    }
    int tripped_axis() const {
        for (int a = 0; a < N; ++a)
            if (axes_[a]->limiter().tripped()) return a;
        return -1;
    }
    Status trip_status(int a) const {
        return in_group("limits", error("trip", N > 1 ? a : -1, trip_reason_name(axes_[a]->limiter().trip_reason())));
    }
    // Every axis at one tick boundary (on one axis, the pipeline's own
    // request already is).
    void arm_all() {
        if constexpr (N > 1) {
            for (PipelineType* p : axes_)
                if (!p->armed()) p->plan_arming();
            mask(true);
            for (PipelineType* p : axes_) p->arm_as_planned();
            mask(false);
        } else {
            axes_[0]->arm();
        }
    }
    void disarm_all() {
        if constexpr (N > 1) mask(true);
        for (PipelineType* p : axes_) p->disarm();
        if constexpr (N > 1) mask(false);
    }

    // An axis index of a request; false once it has replied.
    template <class Send>
    bool check_axis(const FrameHeader& h, uint8_t axis, Send& send) {
        if (axis < N) return true;
        fail(h, ErrorCode::kInvalidParam, error("axis", axis_range_message<N>()), send);
        return false;
    }

    // ---- client loss --------------------------------------------------------
    // A setpoint stream, or a wave or an excitation started without the
    // detached flag, is the client's. A stream that has been sent no
    // setpoints for the link group's client_timeout_s (and is not draining)
    // has lost its feeder, whatever else talks to the board meanwhile; a
    // wave or an excitation is lost when no intact frame arrives for that
    // long, or when a Hello opens another client's session (every host
    // session starts with one), so a later client that keeps the link alive
    // does not keep alive what a killed one started (timeout 0: neither).
    // Then it is stopped (the setpoint holds its last value), the loop is
    // disarmed if on_client_loss says so, and the status reports client_lost
    // until the next stream or wave starts. Checked in the main loop against
    // the tick count: nothing is added to the tick.
    void bind_client(bool bound) {
        client_bound_ = bound;
        client_lost_ = false;
        stream_fed_tick_ = axes_[0]->tick_count();
    }

    void watch_client() {
        if (!client_bound_) return;
        const uint32_t now = axes_[0]->tick_count();
        uint32_t since = 0;
        if (stream_.open()) {
            if (stream_.draining()) return;  // the client said it is done
            since = stream_fed_tick_;
        } else if (any_running()) {
            since = last_frame_tick_;
        } else {
            client_bound_ = false;  // ended on its own
            return;
        }
        const uint32_t timeout = board_.client_timeout_ticks();
        if (timeout == 0 || now - since < timeout) return;
        lose_client();
    }

    // A bound stream (not draining), wave or excitation still running.
    bool bound_run_active() const {
        if (stream_.open()) return !stream_.draining();
        return any_running();
    }

    void lose_client() {
        stream_.stop(false);
        for (PipelineType* p : axes_) {
            p->stop_wave();
            p->stop_excitation();
        }
        if constexpr (kScans) scan_.request_stop();
        if (board_.link().on_client_loss == params::ClientLossAction::kDisarm) disarm_all();
        client_bound_ = false;
        client_lost_ = true;
    }

    void mask(bool m) const {
        if (hooks_.mask_tick != nullptr) hooks_.mask_tick(m);
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

    // StartWave and StartExcitation: every check first, then the start, the
    // arms and the stage restart in one masked section, so the tick after
    // it is tick 0 of all of them. The flag checks and that section are
    // shared (check_flags, check_arm_flags, start_at_tick).
    template <class Send>
    void start_wave(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        StartWave m;
        if (!decode(h, body, m, send)) return;
        const uint8_t f = m.flags;
        if (!check_flags(h, f, "unknown bits: only bit0 arm loop, bit1 arm recorder, bit2 restart stage", send)) return;
        const bool every = N > 1 && m.axis == StartWave::kEveryAxis;
        if (!every && !check_axis(h, m.axis, send)) return;
        const int first = every ? 0 : m.axis;
        const int last = every ? N - 1 : m.axis;
        for (int a = first; a <= last; ++a) {
            const char* why = nullptr;
            ErrorCode code = ErrorCode::kBusy;
            if (!policies_[a].wave_set()) {
                why = "set the trajectory group first";
                code = ErrorCode::kNotConfigured;
            } else if (stream_.open() && stream_axis_ == a) {
                why = "a setpoint stream is running: stop it first";
            } else if (axes_[a]->wave_running()) {
                why = "a wave is running: stop it first";
            } else if (scan_active()) {
                why = "a scan is running: stop it first";
            }
            if (why != nullptr) return fail(h, code, in_group("trajectory", error("waveform", every ? a : -1, why)), send);
        }
        if (!check_arm_flags(h, f, send)) return;
        // Every wave is configured before any starts: a refused one starts none.
        start_at_tick(h, f, true, [&] {
            for (int a = first; a <= last; ++a)
                if (const Status s = axes_[a]->prepare_wave(policies_[a].wave_config()); !s.ok()) return s;
            for (int a = first; a <= last; ++a) axes_[a]->run_wave();
            return ok_status();
        }, send);
    }

    // StartScan: as StartWave, on every axis at once, with the scan feed in
    // place of the axes' waves. The approach starts where the stage is: a
    // loop that stays armed from its held setpoints, else from the
    // readings (a restarted stage's are zero).
    template <class Send>
    void start_scan(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        StartScan m;
        if (!decode(h, body, m, send)) return;
        if constexpr (!kScans) {
            fail(h, ErrorCode::kUnsupported, in_group("scan", error("pattern", "a scan needs a board of two or three axes")),
                 send);
        } else {
            const uint8_t f = m.flags;
            if (!check_flags(h, f, "unknown bits: only bit0 arm loop, bit1 arm recorder, bit2 restart stage, bit3 detached",
                             send))
                return;
            if (scan_.active())
                return fail(h, ErrorCode::kBusy, in_group("scan", error("pattern", "a scan is running: stop it first")), send);
            for (int a = 0; a < N; ++a) {
                const char* why = nullptr;
                if (axes_[a]->wave_running()) why = "a wave is running: stop it first";
                else if (stream_.open() && stream_axis_ == a) why = "a setpoint stream is running: stop it first";
                if (why != nullptr) return fail(h, ErrorCode::kBusy, in_group("trajectory", error("waveform", a, why)), send);
            }
            if (!check_arm_flags(h, f, send)) return;
            start_at_tick(h, f, true, [&] {
                const bool stays_armed = (f & StartWave::kArmLoop) == 0;
                std::array<T, 3> from{};
                std::array<bool, 3> from_reading{};
                for (int a = 0; a < N; ++a) {
                    from_reading[a] = !(stays_armed && axes_[a]->armed());
                    from[a] = from_reading[a] ? axes_[a]->last().y : axes_[a]->setpoint();
                }
                if (const Status s = scan_.start(m.config, from[0], from[1], from[2]); !s.ok()) return s;
                for (int a = 0; a < N; ++a)
                    if (from_reading[a]) axes_[a]->hold_from_reading(from[a]);
                return ok_status();
            }, send);
        }
    }

    // StartExcitation: as StartWave, with the excitation in place of the
    // wave (the setpoint holds). The core checks the configuration and, at
    // the command, that d fits the limits (Pipeline::prepare_excitation).
    template <class Send>
    void start_excitation(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        StartExcitation m;
        if (!decode(h, body, m, send)) return;
        const uint8_t f = m.flags;
        if (!check_flags(h, f, "unknown bits: only bit0 arm loop, bit1 arm recorder, bit2 restart stage, bit3 detached",
                         send))
            return;
        if (!check_axis(h, m.axis, send)) return;
        PipelineType& p = *axes_[m.axis];
        if (p.excitation_running())
            return fail(h, ErrorCode::kBusy, in_group("excitation", error("signal", "an excitation is running: stop it first")), send);
        if ((f & StartExcitation::kArmLoop) == 0 && !p.armed())
            return fail(h, ErrorCode::kNotConfigured, error("flags", "the loop is disarmed: d is applied only while armed (bit0)"), send);
        if (!check_arm_flags(h, f, send)) return;
        ExcitationConfig c = m.config;
        c.sample_rate_Hz = p.setup().rate_Hz;
        // Configured (a multisine tabulated) with the tick running: only
        // the start itself is in the masked section.
        if (const Status s = p.prepare_excitation(c); !s.ok())
            return fail(h, ErrorCode::kInvalidParam, s, send);
        start_at_tick(h, f, false, [&] {
            p.run_excitation();
            return ok_status();
        }, send);
    }

    // Unknown bits, and the restart flag on a device without an emulated
    // stage; false once it has replied.
    template <class Send>
    bool check_flags(const FrameHeader& h, uint8_t f, const char* unknown_bits, Send& send) {
        if ((f & ~StartWave::kKnownFlags) != 0) {
            LinkCounters::inc(counters().bad_value);
            fail(h, ErrorCode::kMalformed, error("flags", unknown_bits), send);
            return false;
        }
        if ((f & StartWave::kRestartStage) != 0 && hooks_.restart_stage == nullptr) {
            fail(h, ErrorCode::kUnsupported, error("flags", "restart stage (bit2): this device has no emulated stage"), send);
            return false;
        }
        return true;
    }

    // Arm loop: not tripped, not armed already (the controller's states
    // would not restart from rest); arm recorder: configured.
    template <class Send>
    bool check_arm_flags(const FrameHeader& h, uint8_t f, Send& send) {
        if ((f & StartWave::kArmLoop) != 0) {
            if (const int a = tripped_axis(); a >= 0) {
                fail(h, ErrorCode::kTripped, trip_status(a), send);
                return false;
            }
            if (any_armed()) {
                fail(h, ErrorCode::kArmed, error("flags", "arm loop (bit0): the loop is armed; disarm first"), send);
                return false;
            }
        }
        if ((f & StartWave::kArmRecorder) != 0 && !recorder_.configured()) {
            fail(h, ErrorCode::kNotConfigured, in_group("recorder", error("channels", "set the recorder group first")), send);
            return false;
        }
        return true;
    }

    // The masked section: the stage's restart, start() (a Status), the
    // arms; then the client binding and the reply.
    // With the arm flag, each axis plans its arming first, with the tick
    // running (Pipeline::arm): from the reading (a restarted stage's is zero)
    // when the start moves the reference from there (`from_reading`: a
    // wave's approach, a scan's), else from the held setpoint.
    template <class Start, class Send>
    void start_at_tick(const FrameHeader& h, uint8_t f, bool from_reading, Start&& start, Send& send) {
        if ((f & StartWave::kArmLoop) != 0) {
            const bool restart = (f & StartWave::kRestartStage) != 0;
            for (PipelineType* p : axes_) p->plan_arming_from(!from_reading ? p->setpoint() : (restart ? T{} : p->last().y));
        }
        mask(true);
        if ((f & StartWave::kRestartStage) != 0) {
            if (!hooks_.restart_stage()) {
                mask(false);
                return fail(h, ErrorCode::kUnsupported, error("flags", "restart stage (bit2): the stage could not restart"), send);
            }
            // A wave's approach starts where the restarted stage is.
            for (PipelineType* p : axes_) p->stage_restarted();
        }
        if (const Status s = start(); !s.ok()) {
            mask(false);
            return fail(h, ErrorCode::kInvalidParam, s, send);
        }
        if ((f & StartWave::kArmLoop) != 0)
            for (PipelineType* p : axes_) p->arm_as_planned();
        if ((f & StartWave::kArmRecorder) != 0) (void)recorder_.arm();  // configured: cannot fail
        mask(false);
        if ((f & StartWave::kArmRecorder) != 0) log_.restart();
        bind_client((f & StartWave::kDetached) == 0);
        ack(h, send);
    }

    // ---- parameter groups -----------------------------------------------------

    // A group's axis: below the axis count, and 0 for a board group; false
    // once it has replied.
    template <class Send>
    bool check_group_axis(const FrameHeader& h, ParamGroup g, uint8_t axis, Send& send) {
        if (board_group(g) && axis != 0) {
            fail(h, ErrorCode::kInvalidParam,
                 in_group(group_name(g), error("axis", "a board group (recorder, link, input_matrix, output_matrix): must be 0")),
                 send);
            return false;
        }
        return check_axis(h, axis, send);
    }

    template <class G>
    G get_group(uint8_t axis) const {
        if constexpr (board_group(G::kGroup)) return board_.template get<G>();
        else return policies_[axis].template get<G>();
    }

    template <class Send>
    void get_params(const FrameHeader& h, const GetParams& m, Send& send) {
        const bool known = params::with_group(m.group, [&](auto tag) {
            using G = typename decltype(tag)::type;
            if (!check_group_axis(h, m.group, m.axis, send)) return;
            ParamsReply<G> r{get_group<G>(m.axis)};
            r.axis = m.axis;
            reply(r, h.seq, send);
        });
        if (!known) fail(h, ErrorCode::kBadGroup, error("group", "unknown parameter group"), send);
    }

    template <class Send>
    void set_params(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        const bool known = params::with_group(static_cast<ParamGroup>(body_group(body)), [&](auto tag) {
            set_group<typename decltype(tag)::type>(h, body, send);
        });
        if (known) return;
        LinkCounters::inc(counters().bad_value);
        fail(h, ErrorCode::kBadGroup, error("group", "unknown parameter group"), send);
    }

    template <class G, class Send>
    void set_group(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        SetParams<G> m;
        if (!decode(h, body, m, send)) return;
        if (!check_group_axis(h, G::kGroup, m.axis, send)) return;
        if constexpr (board_group(G::kGroup)) {
            const Status s = board_.set(m.value);
            if (!s.ok()) return fail(h, board_.code(), s, send);
            if constexpr (G::kGroup == ParamGroup::kRecorder) log_.drop_pending();
        } else {
            ParamPolicy<PipelineType>& policy = policies_[m.axis];
            const Status s = policy.set(m.value);
            if (!s.ok()) return fail(h, policy.code(), s, send);
        }
        ack(h, send);
    }

    // ---- storage ----------------------------------------------------------------

    struct LoadResult {
        StorageState state;
        Status why;
        ErrorCode code;  // of an error reply to Load
    };

    // Reads, checks and applies the stored set (ParamPolicy::set_all).
    LoadResult load_stored() {
        std::span<const uint8_t> bytes;
        if (const Status s = hooks_.storage->read(bytes); !s.ok())
            return {StorageState::kReadFailed, in_group("storage", s), ErrorCode::kStorage};
        const storage::RecordCheck c = storage::decode_stored_params(bytes, info_.firmware_version, stored_);
        switch (c.state) {
            case StorageState::kApplied: break;
            case StorageState::kEmpty: return {c.state, in_group("storage", c.why), ErrorCode::kNotConfigured};
            default: return {c.state, in_group("storage", c.why), ErrorCode::kStorage};
        }
        if (const Status s = check_set(stored_); !s.ok()) return {StorageState::kRejected, s, check_code_};
        if (any_swap_pending())
            return {StorageState::kRejected,
                    error("params", "previous parameter set not yet swapped in; retry after one tick"), ErrorCode::kBusy};
        // Checked as a whole: only a matrix waiting to be taken over can
        // still refuse it, and the board goes first so that changes nothing.
        if (const Status s = board_.set_all(stored_); !s.ok()) return {StorageState::kRejected, s, board_.code()};
        for (int a = 0; a < N; ++a)
            if (const Status s = policies_[a].set_all(stored_.axes[a]); !s.ok())
                return {StorageState::kRejected, s, policies_[a].code()};
        if (stored_.has_recorder) log_.drop_pending();
        return {StorageState::kApplied, ok_status(), ErrorCode::kNone};
    }

    // The one check of a whole set: Save refuses to store, and Load and the
    // load at boot refuse to apply, a set that fails it. On error
    // check_code_ is the reply's code.
    Status check_set(const storage::StoredParams& v) {
        check_code_ = ErrorCode::kInvalidParam;
        if (!(v.loop_rate_Hz == axes_[0]->setup().rate_Hz))
            return in_group("storage", error("loop_rate_Hz", "the set was saved at another loop rate than this board runs (hello)"));
        if (v.axis_count != N)
            return in_group("storage", error("axis_count", "the set was saved on a board with another axis count (hello)"));
        for (int a = 0; a < N; ++a) {
            if (const Status s = policies_[a].check_all(v.axes[a]); !s.ok()) {
                check_code_ = policies_[a].code();
                return s;
            }
        }
        if (const Status s = board_.check_all(v); !s.ok()) {
            check_code_ = board_.code();
            return s;
        }
        return ok_status();
    }

    // The texts are copied at once: a Status may point into a buffer that
    // the next request reuses.
    struct StorageWhy {
        std::array<char, kGroupTextSize> group{};
        std::array<char, kFieldTextSize> field{};
        int16_t index = -1;
        std::array<char, kMessageTextSize> message{};
    };
    void note_boot(const LoadResult& r) {
        boot_state_ = r.state;
        boot_why_ = StorageWhy{};
        if (r.why.ok() || r.state == StorageState::kEmpty) return;  // nothing to explain
        const ErrorReply e = make_error(0, r.code, r.why);
        boot_why_.group = e.group;
        boot_why_.field = e.field;
        boot_why_.index = e.index;
        boot_why_.message = e.message;
    }

    template <class Send>
    void storage_request(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        Save m;  // Save, Load and Forget all have an empty body
        if (!decode(h, body, m, send)) return;
        if (hooks_.storage == nullptr)
            return fail(h, ErrorCode::kUnsupported,
                        error("storage", "this board has no parameter storage (emulated boards: emulate --storage FILE)"),
                        send);
        if (any_armed())
            return fail(h, ErrorCode::kArmed, error("storage", "save, load and forget only while disarmed"), send);
        switch (static_cast<MsgType>(h.type)) {
            case MsgType::kSave: {
                stored_ = storage::StoredParams{};
                stored_.loop_rate_Hz = axes_[0]->setup().rate_Hz;
                stored_.axis_count = static_cast<uint8_t>(N);
                for (int a = 0; a < N; ++a) policies_[a].all(stored_.axes[a]);
                board_.all(stored_);
                set_text(stored_.firmware_version, info_.firmware_version);
                // A set the board would refuse at its next boot is not
                // stored: the record stays as it was.
                if (const Status s = check_set(stored_); !s.ok()) return fail(h, check_code_, s, send);
                const std::size_t n = storage::encode_stored_params(stored_, hooks_.storage->scratch());
                if (n == 0)
                    return fail(h, ErrorCode::kStorage, error("storage", "the record does not fit the storage"), send);
                if (const Status s = hooks_.storage->write(n); !s.ok())
                    return fail(h, ErrorCode::kStorage, in_group("storage", s), send);
                return ack(h, send);
            }
            case MsgType::kLoad: {
                const LoadResult r = load_stored();
                if (r.state != StorageState::kApplied) return fail(h, r.code, r.why, send);
                return ack(h, send);
            }
            default: {
                if (const Status s = hooks_.storage->erase(); !s.ok())
                    return fail(h, ErrorCode::kStorage, in_group("storage", s), send);
                return ack(h, send);
            }
        }
    }

    // ---- setpoint stream ------------------------------------------------------

    template <class Send>
    void setpoints(const FrameHeader& h, std::span<const uint8_t> body, Send& send) {
        SetpointBlock m;
        if (!decode(h, body, m, send)) return;
        int bad = -1;
        using Refusal = typename SetpointStream<T, SetpointCapacity>::Refusal;
        switch (stream_.push(m, axes_[stream_axis_]->setup().position, bad)) {
            case Refusal::kNone:
                stream_fed_tick_ = axes_[0]->tick_count();
                return reply(stream_.ack(), h.seq, send);
            case Refusal::kNotOpen:
                return fail(h, ErrorCode::kNotConfigured, error("stream", "no stream open: send StreamStart first"), send);
            case Refusal::kSequence:
                return fail(h, ErrorCode::kSequence, error("block_seq", "out of sequence: block dropped (status: setpoint_next_seq)"), send);
            case Refusal::kValue:
                return fail(h, ErrorCode::kInvalidParam, error("setpoint_um", bad, "must be finite and within +-1e6 um"), send);
            case Refusal::kNoSpace:
                return fail(h, ErrorCode::kNoSpace, error("count", "more setpoints than free FIFO slots: block dropped"), send);
        }
    }

    std::array<PipelineType*, N> axes_;
    std::conditional_t<MultiAxis, MultiType*, void*> multi_;  // the matrices and channels (MultiAxis)
    RecorderType& recorder_;
    DeviceInfo info_;
    DeviceHooks hooks_;
    FrameDecoder decoder_{};
    std::array<uint8_t, kMaxFrameSize> tx_{};
    TickStats tick_stats_{};
    std::array<ParamPolicy<PipelineType>, N> policies_;
    BoardPolicy<T, N, RecorderType, std::conditional_t<MultiAxis, MultiType, void>> board_;
    ErrorCode check_code_ = ErrorCode::kInvalidParam;  // of check_set's last error
    uint8_t stream_axis_ = 0;  // the axis the setpoint stream feeds
    uint32_t last_frame_tick_ = 0;
    uint32_t stream_fed_tick_ = 0;  // tick of the last setpoint block accepted
    bool client_bound_ = false;
    bool client_lost_ = false;
    SetpointStream<T, SetpointCapacity> stream_{};
    LogStreamType log_{};
    StorageState boot_state_ = StorageState::kAbsent;
    StorageWhy boot_why_{};
    storage::StoredParams stored_{};  // scratch of Save and Load (kept off the main loop's stack)
    std::conditional_t<kScans, DeviceScan<T, MultiType>, NoScan> scan_;
};

}  // namespace piezoloop::link
