// Host side of the link protocol (docs/protocol.md) over any Transport:
// one request at a time, each with its own sequence id, waiting at most the
// timeout for the reply with that id. An Error reply becomes a DeviceError
// whose text names the request, the code, group.field[index] and what is
// allowed. LogBlocks the device sends while a reply is awaited are queued
// into the LogCollector (nothing is dropped); replies with a stale sequence
// id (after a timeout) and undecodable frames are counted.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "link/log_collector.hpp"
#include "link/transport.hpp"
#include "piezoloop/link/framing.hpp"
#include "piezoloop/link/messages.hpp"
#include "piezoloop/params/field_check.hpp"
#include "status_text.hpp"

namespace piezoloop::hostlink {

// The device answered a request with Error.
class DeviceError : public LinkError {
public:
    DeviceError(const std::string& what, const link::ErrorReply& e) : LinkError(what), reply_(e) {}
    const link::ErrorReply& reply() const { return reply_; }
    link::ErrorCode code() const { return reply_.code; }
    std::string group() const { return reply_.group.data(); }
    std::string field() const { return reply_.field.data(); }

private:
    link::ErrorReply reply_;
};

// "group.field[index]: message" of an error reply (the core's Status texts).
std::string describe(const link::ErrorReply& e);
const char* request_name(uint8_t type);

// StartWave flags (the flags byte of StartWave; all act at the wave's first
// tick).
namespace wave_flag {
inline constexpr uint8_t kArm = link::StartWave::kArmLoop;               // arm the loop
inline constexpr uint8_t kArmRecorder = link::StartWave::kArmRecorder;   // arm the recorder
inline constexpr uint8_t kRestartStage = link::StartWave::kRestartStage; // restart the emulated stage at rest
inline constexpr uint8_t kDetached = link::StartWave::kDetached;         // keep running when this client goes silent
}  // namespace wave_flag

struct ClientCounters {
    uint64_t requests = 0;
    uint64_t stale_replies = 0;    // a reply whose seq is not the awaited one (dropped)
    uint64_t bad_replies = 0;      // a frame with a good CRC but an undecodable body (dropped)
    uint64_t busy_retries = 0;     // SetParams retried after Error(busy)
    uint64_t log_blocks = 0;       // LogBlocks received
    uint64_t bytes_received = 0;   // from the transport, frames or not
};

struct StreamResult {
    uint64_t sent = 0;          // setpoints acknowledged by the device
    uint64_t consumed = 0;      // setpoints the tick consumed
    uint32_t underruns = 0;     // ticks that found the FIFO empty
    uint64_t blocks = 0;
    uint16_t capacity = 0;
    bool drained = false;       // the device ended the stream after the last setpoint
    double wall_s = 0.0;
};

class Client {
public:
    struct Options {
        std::chrono::milliseconds timeout{2000};  // per request
    };
    explicit Client(std::unique_ptr<Transport> transport);
    Client(std::unique_ptr<Transport> transport, Options options);

    Transport& transport() { return *transport_; }
    const std::string address() const { return transport_->address(); }

    // Hello: reads the board's identity and limits, checks the protocol
    // version (LinkError if the device speaks another one). Cached in info().
    const link::HelloReply& hello();
    const link::HelloReply& info();  // hello() once, then the cached reply

    link::StatusReply status();

    // The board's axis count (hello; 1 for a single-axis board).
    uint8_t axis_count() { return info().axis_count; }

    // A group of `axis` (an axis's group) or of the board (recorder, link,
    // matrices: axis 0 whatever `axis` says).
    template <class G>
    G get(uint8_t axis = 0) {
        link::GetParams m;
        m.group = G::kGroup;
        m.axis = link::board_group(G::kGroup) ? uint8_t{0} : axis;
        return request<link::ParamsReply<G>>(m).value;
    }
    // SetParams, retried while the device answers busy (previous set not
    // yet swapped in) until the timeout.
    // The group is checked against its declaration first (the check the
    // board runs): std::invalid_argument naming the field, nothing sent.
    template <class G>
    void set(const G& v, uint8_t axis = 0) {
        params::FieldCheck check;
        if (const Status s = check.check(v); !s.ok()) throw std::invalid_argument(describe(s));
        link::SetParams<G> m;
        m.value = v;
        m.axis = link::board_group(G::kGroup) ? uint8_t{0} : axis;
        const auto deadline = std::chrono::steady_clock::now() + options_.timeout;
        for (;;) {
            try {
                expect_ack(m);
                return;
            } catch (const DeviceError& e) {
                if (e.code() != link::ErrorCode::kBusy || e.field() != "params" ||
                    std::chrono::steady_clock::now() > deadline)
                    throw;
                ++counters_.busy_retries;
                std::this_thread::sleep_for(std::chrono::milliseconds(1));
            }
        }
    }

    void arm();
    void disarm();
    void clear_trip();
    // The board's parameter storage (cap::kStorage): store the current set,
    // validate and apply the stored one, erase it. Save and Forget wait up
    // to kStorageTimeout (a flash sector erase takes seconds).
    void save();
    void load();
    void forget();
    static constexpr std::chrono::milliseconds kStorageTimeout{10000};
    // start_excitation waits at least this long: the board tabulates a
    // multisine's period before it replies.
    static constexpr std::chrono::milliseconds kExcitationTimeout{30000};
    // The axis's trajectory group (flags: wave_flag::*; arm and restart act
    // on every axis).
    void start_wave(uint8_t flags = 0, uint8_t axis = 0);
    void stop_wave(uint8_t axis = 0);
    // Every axis's wave (a board of axes has one per axis); the setpoints hold.
    void stop_waves();
    // An excitation of one axis at the next tick (flags: wave_flag::*, the
    // same bits); the board's loop rate replaces c.sample_rate_Hz.
    void start_excitation(const ExcitationConfig& c, uint8_t flags = 0, uint8_t axis = 0);
    void stop_excitation(uint8_t axis = 0);
    // A scan on a board of two or three axes (cap::kScan; flags:
    // wave_flag::*); the board's loop rate replaces c.sample_rate_Hz.
    // stop_waves() stops it.
    void start_scan(const ScanConfig& c, uint8_t flags = 0);

    // A setpoint stream to one axis.
    link::SetpointAck stream_start(uint16_t prefill, uint8_t axis = 0);
    // One Setpoints block (<= 120 values) with the next block_seq.
    link::SetpointAck send_setpoints(std::span<const float> setpoints_um);
    void stream_stop(bool drain);
    // Streams every setpoint, keeping the FIFO filled by the free counts of
    // the SetpointAcks (and status when it is full), then drains.
    StreamResult stream(std::span<const float> setpoints_um, uint16_t prefill,
                        const std::function<void(double)>& progress = {}, uint8_t axis = 0);

    void recorder_arm();   // also clears the log collector
    void recorder_stop();

    // Reads whatever arrives within `timeout` (log blocks into log());
    // returns the number of LogBlocks received.
    std::size_t pump(std::chrono::milliseconds timeout);
    LogCollector& log() { return log_; }
    const ClientCounters& counters() const { return counters_; }
    const link::LinkCounters& link_counters() const { return decoder_.counters(); }

    // A raw request: type and body bytes; returns the reply payload's type
    // and body (Error replies are returned, not thrown). For tests and tools.
    struct RawReply {
        uint8_t type = 0;
        uint16_t seq = 0;
        std::vector<uint8_t> body;
    };
    RawReply transact(uint8_t type, std::span<const uint8_t> body, uint8_t version = link::kProtocolVersion);

    // Encodes m's body and sends it; decodes the reply as R; throws
    // DeviceError for an Error reply, LinkError for anything else unexpected.
    template <class R, class M>
    R request(const M& m) {
        std::array<uint8_t, link::kMaxBody> body{};
        link::Writer w(body);
        m.write(w);
        if (!w.ok()) throw LinkError(address() + ": " + request_name(static_cast<uint8_t>(M::kType)) + ": body too long");
        const RawReply r = transact(static_cast<uint8_t>(M::kType), std::span<const uint8_t>(body.data(), w.size()));
        return decode_reply<R>(r, static_cast<uint8_t>(M::kType));
    }

private:
    template <class M>
    void expect_ack(const M& m) {
        const link::Ack a = request<link::Ack>(m);
        check_ack(a, static_cast<uint8_t>(M::kType));
    }
    void check_ack(const link::Ack& a, uint8_t type);

    template <class R>
    R decode_reply(const RawReply& r, uint8_t request_type) {
        throw_if_error(r, request_type);
        R out{};
        if (r.type != static_cast<uint8_t>(R::kType) ||
            link::decode_body(std::span<const uint8_t>(r.body), out) != link::DecodeResult::kOk)
            unexpected(r, request_type);
        return out;
    }
    void throw_if_error(const RawReply& r, uint8_t request_type);
    [[noreturn]] void unexpected(const RawReply& r, uint8_t request_type);
    void on_payload(std::span<const uint8_t> payload);
    void read_some(std::chrono::milliseconds timeout);
    void send_frame(uint8_t type, uint16_t seq, std::span<const uint8_t> body, uint8_t version);

    // A tenth of the board's default client timeout (1 s): an emulated board's
    // clock may run ahead of the host's.
    static constexpr std::chrono::milliseconds kKeepAliveInterval{100};

    std::unique_ptr<Transport> transport_;
    Options options_;
    link::FrameDecoder decoder_;
    std::optional<link::HelloReply> hello_;
    uint16_t seq_ = 0;
    std::optional<uint16_t> awaited_;
    std::optional<uint16_t> keepalive_seq_;
    std::chrono::steady_clock::time_point last_sent_{};
    std::optional<RawReply> reply_;
    uint32_t next_block_seq_ = 0;
    LogCollector log_;
    ClientCounters counters_;
};

// Physical value (µm or V) of a raw log sample of signal `signal_id`, in the
// block format (float32 bits, or Q31 through the core's SignalScale with the
// hello's full scale: raw * full scale / 2^31, rounded to float).
double log_sample_physical(uint32_t raw, uint8_t signal_id, link::SampleFormat format, const link::HelloReply& hello);
// Unit of a signal id: "um" for r, y, e, "V" for u, u_ff, u_fb, u_rc.
const char* signal_unit(uint8_t signal_id);
const char* signal_name(uint8_t signal_id);  // r, y, e, u, u_ff, u_fb, u_rc, sync

}  // namespace piezoloop::hostlink
