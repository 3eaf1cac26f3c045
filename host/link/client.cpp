#include "link/client.hpp"

#include <algorithm>
#include <cmath>

#include "piezoloop/axes/multi_axis_pipeline.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"

namespace piezoloop::hostlink {

using namespace std::chrono;
using link::MsgType;

const char* request_name(uint8_t type) {
    switch (static_cast<MsgType>(type)) {
        case MsgType::kHello: return "Hello";
        case MsgType::kGetStatus: return "GetStatus";
        case MsgType::kGetParams: return "GetParams";
        case MsgType::kSetParams: return "SetParams";
        case MsgType::kArm: return "Arm";
        case MsgType::kDisarm: return "Disarm";
        case MsgType::kClearTrip: return "ClearTrip";
        case MsgType::kStartWave: return "StartWave";
        case MsgType::kStopWave: return "StopWave";
        case MsgType::kStreamStart: return "StreamStart";
        case MsgType::kSetpoints: return "Setpoints";
        case MsgType::kStreamStop: return "StreamStop";
        case MsgType::kRecorderArm: return "RecorderArm";
        case MsgType::kRecorderStop: return "RecorderStop";
        case MsgType::kStartExcitation: return "StartExcitation";
        case MsgType::kStopExcitation: return "StopExcitation";
        case MsgType::kSave: return "Save";
        case MsgType::kLoad: return "Load";
        case MsgType::kForget: return "Forget";
        default: return "request";
    }
}

std::string describe(const link::ErrorReply& e) {
    std::string t;
    if (e.group[0] != '\0') {
        t += e.group.data();
        t += '.';
    }
    t += e.field[0] != '\0' ? e.field.data() : "?";
    if (e.index >= 0) {
        t += '[';
        t += std::to_string(e.index);
        t += ']';
    }
    t += ": ";
    t += e.message[0] != '\0' ? e.message.data() : "invalid";
    return t;
}

Client::Client(std::unique_ptr<Transport> transport) : Client(std::move(transport), Options{}) {}

Client::Client(std::unique_ptr<Transport> transport, Options options)
    : transport_(std::move(transport)), options_(options) {
    if (!transport_) throw LinkError("no transport");
}

void Client::on_payload(std::span<const uint8_t> payload) {
    if (payload.size() < link::kHeaderSize) {
        ++counters_.bad_replies;
        return;
    }
    const link::FrameHeader h = link::parse_header(payload);
    const auto body = payload.subspan(link::kHeaderSize);
    if (h.type == static_cast<uint8_t>(MsgType::kLogBlock)) {
        link::LogBlock b;
        if (link::decode_body(body, b) != link::DecodeResult::kOk) {
            ++counters_.bad_replies;
            return;
        }
        ++counters_.log_blocks;
        log_.add(b);
        return;
    }
    if (keepalive_seq_ && h.seq == *keepalive_seq_) {
        keepalive_seq_.reset();  // a keep-alive's status: taken in passing
        return;
    }
    if (!awaited_ || h.seq != *awaited_ || reply_) {
        ++counters_.stale_replies;
        return;
    }
    RawReply r;
    r.type = h.type;
    r.seq = h.seq;
    r.body.assign(body.begin(), body.end());
    reply_ = std::move(r);
}

void Client::read_some(milliseconds timeout) {
    std::array<uint8_t, 4096> buf;
    const std::size_t n = transport_->read(buf, timeout);
    if (n == 0) return;
    counters_.bytes_received += n;
    decoder_.feed(std::span<const uint8_t>(buf.data(), n), [this](std::span<const uint8_t> p) { on_payload(p); });
}

void Client::send_frame(uint8_t type, uint16_t seq, std::span<const uint8_t> body, uint8_t version) {
    std::array<uint8_t, link::kMaxFrameSize + 1> frame{};
    // A leading delimiter ends any partial frame a previous session left in
    // the device's receiver (an empty frame is idle fill, not counted).
    frame[0] = 0;
    const std::size_t n = link::encode_frame(type, version, seq, body, std::span<uint8_t>(frame).subspan(1));
    if (n == 0) throw LinkError(address() + ": " + request_name(type) + ": frame does not fit");
    ++counters_.requests;
    transport_->write(std::span<const uint8_t>(frame.data(), n + 1));
    last_sent_ = steady_clock::now();
}

std::size_t Client::pump(milliseconds timeout) {
    // While the host only listens (a record), the board must still hear from
    // it, or it stops the wave this client started (link group,
    // client_timeout_s): a status request now and then, its reply taken in
    // passing.
    if (steady_clock::now() - last_sent_ > kKeepAliveInterval) {
        const uint16_t seq = ++seq_;
        keepalive_seq_ = seq;
        send_frame(static_cast<uint8_t>(MsgType::kGetStatus), seq, {}, link::kProtocolVersion);
    }
    const uint64_t before = counters_.log_blocks;
    const auto deadline = steady_clock::now() + timeout;
    do {
        const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
        read_some(std::max(left, milliseconds(0)));
    } while (steady_clock::now() < deadline && counters_.log_blocks == before);
    // Take whatever else is already waiting, without blocking.
    for (int i = 0; i < 64; ++i) {
        const uint64_t b = counters_.log_blocks;
        read_some(milliseconds(0));
        if (counters_.log_blocks == b) break;
    }
    return static_cast<std::size_t>(counters_.log_blocks - before);
}

Client::RawReply Client::transact(uint8_t type, std::span<const uint8_t> body, uint8_t version) {
    const uint16_t seq = ++seq_;
    awaited_ = seq;
    reply_.reset();
    send_frame(type, seq, body, version);
    const auto deadline = steady_clock::now() + options_.timeout;
    while (!reply_) {
        const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
        if (left.count() <= 0) {
            awaited_.reset();
            std::string text = address() + ": no reply to " + request_name(type) + " within " +
                               std::to_string(options_.timeout.count()) + " ms";
            // Silence from the first request: a board serves one connection
            // at a time (the emulated one queues a second TCP client without
            // answering it), so the usual cause is another client.
            if (counters_.bytes_received == 0)
                text += ", and nothing at all was received: the board is busy with another client (it serves "
                        "one connection at a time: wait for the other piezoloop command or stop it), or the "
                        "address is not a piezoloop board";
            throw LinkError(text);
        }
        read_some(left);
    }
    awaited_.reset();
    RawReply r = std::move(*reply_);
    reply_.reset();
    return r;
}

void Client::throw_if_error(const RawReply& r, uint8_t request_type) {
    if (r.type != static_cast<uint8_t>(MsgType::kError)) return;
    link::ErrorReply e;
    if (link::decode_body(std::span<const uint8_t>(r.body), e) != link::DecodeResult::kOk)
        unexpected(r, request_type);
    throw DeviceError(address() + ": " + request_name(request_type) + " refused (" + link::error_code_name(e.code) +
                          "): " + describe(e),
                      e);
}

void Client::unexpected(const RawReply& r, uint8_t request_type) {
    ++counters_.bad_replies;
    char t[8];
    std::snprintf(t, sizeof t, "0x%02X", r.type);
    throw LinkError(address() + ": unexpected reply " + t + " (" + std::to_string(r.body.size()) + " bytes) to " +
                    request_name(request_type));
}

void Client::check_ack(const link::Ack& a, uint8_t type) {
    if (a.request_type != type)
        throw LinkError(address() + ": Ack names request " + std::to_string(a.request_type) + ", expected " +
                        request_name(type));
}

const link::HelloReply& Client::hello() {
    const RawReply r = transact(static_cast<uint8_t>(MsgType::kHello), {});
    throw_if_error(r, static_cast<uint8_t>(MsgType::kHello));
    if (r.type != static_cast<uint8_t>(MsgType::kHelloReply) || r.body.empty())
        unexpected(r, static_cast<uint8_t>(MsgType::kHello));
    if (r.body[0] != link::kProtocolVersion)
        throw LinkError(address() + ": the device speaks link protocol version " + std::to_string(r.body[0]) +
                        ", this host speaks version " + std::to_string(link::kProtocolVersion) +
                        " (update the firmware or the host tools)");
    hello_ = decode_reply<link::HelloReply>(r, static_cast<uint8_t>(MsgType::kHello));
    return *hello_;
}

const link::HelloReply& Client::info() {
    if (!hello_) hello();
    return *hello_;
}

link::StatusReply Client::status() { return request<link::StatusReply>(link::GetStatus{}); }

void Client::arm() { expect_ack(link::Arm{}); }
void Client::disarm() { expect_ack(link::Disarm{}); }
void Client::clear_trip() { expect_ack(link::ClearTrip{}); }
void Client::stop_wave(uint8_t axis) {
    link::StopWave m;
    m.axis = axis;
    expect_ack(m);
}
void Client::stop_waves() {
    for (uint8_t a = 0; a < axis_count(); ++a) stop_wave(a);
}

namespace {
// Lengthens the per-request timeout for one request.
struct LongerTimeout {
    Client::Options& o;
    milliseconds saved;
    LongerTimeout(Client::Options& options, milliseconds at_least) : o(options), saved(options.timeout) {
        if (o.timeout < at_least) o.timeout = at_least;
    }
    ~LongerTimeout() { o.timeout = saved; }
};
}  // namespace

void Client::start_excitation(const ExcitationConfig& c, uint8_t flags, uint8_t axis) {
    if (flags & wave_flag::kArmRecorder) log_.clear();
    link::StartExcitation m;
    m.axis = axis;
    m.flags = flags;
    m.config = c;
    // A multisine's period is tabulated before the reply: N K table steps
    // in the board's main loop (16384 x 6500 ~ 1e8 on the QEMU boards).
    LongerTimeout t(options_, kExcitationTimeout);
    expect_ack(m);
}

void Client::stop_excitation(uint8_t axis) {
    link::StopExcitation m;
    m.axis = axis;
    expect_ack(m);
}

void Client::save() {
    LongerTimeout t(options_, kStorageTimeout);
    expect_ack(link::Save{});
}
void Client::load() {
    LongerTimeout t(options_, kStorageTimeout);
    expect_ack(link::Load{});
}
void Client::forget() {
    LongerTimeout t(options_, kStorageTimeout);
    expect_ack(link::Forget{});
}

void Client::start_wave(uint8_t flags, uint8_t axis) {
    if (flags & wave_flag::kArmRecorder) log_.clear();
    link::StartWave m;
    m.flags = flags;
    m.axis = axis;
    expect_ack(m);
}

void Client::start_scan(const ScanConfig& c, uint8_t flags) {
    if (flags & wave_flag::kArmRecorder) log_.clear();
    link::StartScan m;
    m.flags = flags;
    m.config = c;
    expect_ack(m);
}

void Client::recorder_arm() {
    log_.clear();
    expect_ack(link::RecorderArm{});
}
void Client::recorder_stop() { expect_ack(link::RecorderStop{}); }

link::SetpointAck Client::stream_start(uint16_t prefill, uint8_t axis) {
    link::StreamStart m;
    m.prefill = prefill;
    m.axis = axis;
    const link::SetpointAck a = request<link::SetpointAck>(m);
    next_block_seq_ = a.next_block_seq;
    return a;
}

link::SetpointAck Client::send_setpoints(std::span<const float> sp) {
    if (sp.size() > link::kMaxSetpointsPerBlock)
        throw std::invalid_argument("send_setpoints: at most 120 setpoints per block");
    link::SetpointBlock b;
    b.block_seq = next_block_seq_;
    b.count = static_cast<uint8_t>(sp.size());
    std::copy(sp.begin(), sp.end(), b.setpoint_um.begin());
    const link::SetpointAck a = request<link::SetpointAck>(b);
    next_block_seq_ = a.next_block_seq;
    return a;
}

void Client::stream_stop(bool drain) {
    link::StreamStop m;
    m.drain = drain;
    expect_ack(m);
}

StreamResult Client::stream(std::span<const float> sp, uint16_t prefill, const std::function<void(double)>& progress,
                            uint8_t axis) {
    const auto t0 = steady_clock::now();
    const double rate = info().loop_rate_Hz > 0.0f ? info().loop_rate_Hz : 100000.0;
    // Checked before anything moves, as the board checks each block: a bad
    // value found half-way would leave the stream open with the stage moving.
    for (std::size_t j = 0; j < sp.size(); ++j)
        if (!(std::isfinite(sp[j]) && std::fabs(sp[j]) <= 1.0e6f))
            throw std::invalid_argument("setpoint " + std::to_string(j) + ": " + std::to_string(sp[j]) +
                                        " um: must be finite and within +-1e6 um");
    StreamResult res;
    link::SetpointAck ack = stream_start(prefill, axis);
    // Whatever ends the stream early (a refused block, a lost link, Ctrl-C
    // turned into an exception) closes it on the board, so no stream is left
    // behind (the board's client timeout would close it too, later).
    struct CloseOnError {
        Client& c;
        bool done = false;
        ~CloseOnError() {
            if (done) return;
            try {
                c.stream_stop(false);
            } catch (...) {
            }
        }
    } close_on_error{*this};
    res.capacity = ack.capacity;
    std::size_t free = ack.free;
    std::size_t i = 0;
    auto last_progress = steady_clock::now();
    while (i < sp.size()) {
        std::size_t k = std::min<std::size_t>(link::kMaxSetpointsPerBlock, sp.size() - i);
        // A full block when it fits; a partial one only while the device has
        // not started and holds fewer than `prefill` setpoints (blocks of 120
        // may never add up to the prefill, e.g. the whole 1024-slot FIFO, and
        // the device would never start), else wait for room.
        const bool low = ack.consumed == 0 && res.capacity - free < prefill;
        if (free == 0 || (free < k && !low)) {
            // Wait about as long as the tick needs to make room, then ask.
            const double wait_s = static_cast<double>(k - std::min(k, free)) / rate;
            pump(milliseconds(std::clamp<long>(static_cast<long>(wait_s * 1000.0), 1, 50)));
            const link::StatusReply st = status();
            if (st.setpoint_free != free) last_progress = steady_clock::now();
            free = st.setpoint_free;
            if (free < k && steady_clock::now() - last_progress > 5 * options_.timeout)
                throw LinkError(address() + ": setpoint stream stalled: the FIFO stays full (" +
                                std::to_string(res.capacity) + " setpoints) and the device consumes none" +
                                (st.streaming ? "" : " (it is not streaming any more)"));
            continue;
        }
        k = std::min(k, free);
        ack = send_setpoints(sp.subspan(i, k));
        free = ack.free;
        i += k;
        res.sent += k;
        ++res.blocks;
        res.consumed = ack.consumed;
        res.underruns = ack.underruns;
        last_progress = steady_clock::now();
        if (progress) progress(static_cast<double>(i) / static_cast<double>(sp.size()));
    }
    close_on_error.done = true;
    stream_stop(true);
    // The drained stream ends when its FIFO runs empty: wait for that
    // (about capacity / rate) and read the final counts.
    const auto deadline = steady_clock::now() + options_.timeout +
                          milliseconds(static_cast<long>(1000.0 * (res.capacity + 1) / rate));
    for (;;) {
        const link::StatusReply st = status();
        res.underruns = st.setpoint_underruns;
        if (!st.streaming) {
            res.drained = true;
            res.consumed = res.sent;
            break;
        }
        if (steady_clock::now() > deadline) break;
        pump(milliseconds(2));
    }
    res.wall_s = duration<double>(steady_clock::now() - t0).count();
    return res;
}

// A log channel id is axis * kSignalCount + signal, or the board's sync
// word (docs/protocol.md, LogBlock).
const char* signal_name(uint8_t id) {
    if (id == kBoardSyncSignal) return "sync";
    return id < link::kMaxLinkAxes * kSignalCount ? piezoloop::signal_name(static_cast<SignalId>(id % kSignalCount))
                                                   : "?";
}

// d is recorded in volts: the measurements add it at the command.
const char* signal_unit(uint8_t id) { return id % kSignalCount <= 2 ? "um" : "V"; }

double log_sample_physical(uint32_t raw, uint8_t id, link::SampleFormat format, const link::HelloReply& hello) {
    if (format == link::SampleFormat::kFloat32) return static_cast<double>(std::bit_cast<float>(raw));
    // The core's own conversion (SignalScale::to_physical, in float), so a
    // Q31 record prints the values `piezoloop sim --sample q31` prints.
    // Axis 0's full scales are the hello's first ones; every axis's follow.
    const std::size_t axis = id / kSignalCount;
    const bool position = id % kSignalCount <= 2;
    float fs = position ? hello.position_full_scale_um : hello.voltage_full_scale_V;
    if (axis > 0 && axis < hello.axis_count && axis < link::kMaxLinkAxes)
        fs = position ? hello.axis_position_full_scale_um[axis] : hello.axis_voltage_full_scale_V[axis];
    const SignalScale scale{fs};
    return static_cast<double>(scale.to_physical(Q31::from_raw(static_cast<int32_t>(raw))));
}

}  // namespace piezoloop::hostlink
