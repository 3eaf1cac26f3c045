// Frames on a byte stream (UART, TCP, USB bulk):
//
//   frame   = COBS(payload ++ crc32_le(payload)) ++ 0x00
//   payload = type:u8  version:u8  seq:u16le  body (message layout, <= 508 bytes)
//
// The 0x00 delimiter resynchronises a receiver after any garbage; the CRC-32
// (IEEE 802.3) covers the whole payload. FrameDecoder accepts arbitrary chunks
// of the stream and hands every intact payload to a callback; every frame it
// throws away is counted by reason in LinkCounters, so nothing is ever lost
// silently. Empty frames (0x00 0x00) are idle fill and are not counted.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "piezoloop/link/cobs.hpp"
#include "piezoloop/link/crc32.hpp"
#include "piezoloop/link/wire.hpp"

namespace piezoloop::link {

inline constexpr std::size_t kHeaderSize = 4;     // type, version, seq
inline constexpr std::size_t kCrcSize = 4;
inline constexpr std::size_t kMaxPayload = 512;   // header + body, without CRC
inline constexpr std::size_t kMaxBody = kMaxPayload - kHeaderSize;
// Longest frame on the wire, delimiter included (520 bytes).
inline constexpr std::size_t kMaxFrameSize = cobs_max_encoded_size(kMaxPayload + kCrcSize) + 1;

// Counts of everything the link threw away or refused, by reason. uint32,
// saturating. Framing reasons are counted by FrameDecoder, message reasons
// (unknown type, version, length, values) by the dispatcher.
struct LinkCounters {
    uint32_t frames_ok = 0;     // frames with a good CRC handed on
    uint32_t bad_cobs = 0;      // COBS code byte runs past the delimiter
    uint32_t bad_crc = 0;       // CRC mismatch
    uint32_t truncated = 0;     // shorter than header + CRC, or than the message layout
    uint32_t oversize = 0;      // more than kMaxFrameSize bytes before a delimiter
    uint32_t unknown_type = 0;  // message type the receiver does not handle
    uint32_t bad_version = 0;   // header version is not kProtocolVersion
    uint32_t bad_length = 0;    // body longer than the message layout
    uint32_t bad_value = 0;     // a boolean that is not 0/1, a count beyond its array
    uint32_t error_replies = 0; // error replies sent (dispatcher)
    bool operator==(const LinkCounters&) const = default;

    static constexpr void inc(uint32_t& c) { if (c != 0xffffffffu) ++c; }
    constexpr uint32_t dropped() const {
        return bad_cobs + bad_crc + truncated + oversize + unknown_type + bad_version + bad_length + bad_value;
    }
};

struct FrameHeader {
    uint8_t type = 0;
    uint8_t version = 0;
    uint16_t seq = 0;
};

// Header of a payload of at least kHeaderSize bytes.
constexpr FrameHeader parse_header(std::span<const uint8_t> payload) {
    Reader r(payload);
    FrameHeader h;
    h.type = r.u8();
    h.version = r.u8();
    h.seq = r.u16();
    return h;
}

// Finishes a frame whose payload (header + body, n bytes) is already in
// scratch[0, n): appends the CRC there (scratch needs n + 4 bytes), COBS-encodes
// into out and appends the delimiter. Returns the frame length, 0 if it does
// not fit.
constexpr std::size_t seal_frame(std::span<uint8_t> scratch, std::size_t n, std::span<uint8_t> out) {
    if (n > kMaxPayload || scratch.size() < n + kCrcSize) return 0;
    const uint32_t crc = crc32(scratch.first(n));
    for (std::size_t i = 0; i < kCrcSize; ++i) scratch[n + i] = static_cast<uint8_t>(crc >> (8 * i));
    if (out.empty()) return 0;
    const std::size_t m = cobs_encode(scratch.first(n + kCrcSize), out.first(out.size() - 1));
    if (m == 0) return 0;
    out[m] = 0;
    return m + 1;
}

// A frame from a header and a body given as bytes.
constexpr std::size_t encode_frame(uint8_t type, uint8_t version, uint16_t seq, std::span<const uint8_t> body,
                                   std::span<uint8_t> out) {
    if (body.size() > kMaxBody) return 0;
    std::array<uint8_t, kMaxPayload + kCrcSize> scratch{};
    Writer w(scratch);
    w.u8(type);
    w.u8(version);
    w.u16(seq);
    for (const uint8_t b : body) w.u8(b);
    return seal_frame(scratch, w.size(), out);
}

// Streaming receiver. Holds at most one encoded frame (kMaxFrameSize bytes).
class FrameDecoder {
public:
    // Feeds a chunk of the stream; on_payload(std::span<const uint8_t>) is
    // called with the payload (header + body, CRC removed) of every intact
    // frame, valid only during the call.
    template <class OnPayload>
    void feed(std::span<const uint8_t> bytes, OnPayload&& on_payload) {
        for (const uint8_t b : bytes) {
            if (b != 0) {
                if (discarding_) continue;
                if (n_ == buf_.size()) {
                    // Too long to be a frame: drop it up to the next delimiter.
                    LinkCounters::inc(counters_.oversize);
                    discarding_ = true;
                    n_ = 0;
                    continue;
                }
                buf_[n_++] = b;
                continue;
            }
            // Delimiter.
            const std::size_t n = n_;
            n_ = 0;
            if (discarding_) { discarding_ = false; continue; }
            if (n == 0) continue;  // idle fill
            const CobsResult d = cobs_decode(std::span<const uint8_t>(buf_.data(), n), buf_);
            if (d.error != CobsError::kOk) { LinkCounters::inc(counters_.bad_cobs); continue; }
            if (d.size > kMaxPayload + kCrcSize) { LinkCounters::inc(counters_.oversize); continue; }
            if (d.size < kHeaderSize + kCrcSize) { LinkCounters::inc(counters_.truncated); continue; }
            const std::size_t p = d.size - kCrcSize;
            const uint32_t crc = static_cast<uint32_t>(buf_[p]) | static_cast<uint32_t>(buf_[p + 1]) << 8 |
                                 static_cast<uint32_t>(buf_[p + 2]) << 16 | static_cast<uint32_t>(buf_[p + 3]) << 24;
            if (crc != crc32(std::span<const uint8_t>(buf_.data(), p))) {
                LinkCounters::inc(counters_.bad_crc);
                continue;
            }
            LinkCounters::inc(counters_.frames_ok);
            on_payload(std::span<const uint8_t>(buf_.data(), p));
        }
    }

    // Forget a partial frame (e.g. after the transport reconnects).
    void reset() { n_ = 0; discarding_ = false; }

    LinkCounters& counters() { return counters_; }
    const LinkCounters& counters() const { return counters_; }

private:
    std::array<uint8_t, kMaxFrameSize - 1> buf_{};  // encoded bytes without the delimiter
    std::size_t n_ = 0;
    bool discarding_ = false;
    LinkCounters counters_{};
};

}  // namespace piezoloop::link
