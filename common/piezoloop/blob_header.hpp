// The header in front of every blob the host writes for a board to find in
// memory (the emulation profile, emulation_profile.hpp; a board case,
// board_case.hpp): what it is, which layout, how long, and a CRC over the
// body, so a board can tell a valid blob from whatever the RAM holds.
//
// Layout, little-endian, 16 bytes, then the body:
//     0  u32  magic (the blob kind's four ASCII letters in memory order)
//     4  u16  version of the body layout
//     6  u16  reserved, 0
//     8  u32  body length in bytes
//    12  u32  CRC-32 (link/crc32.hpp, IEEE 802.3) of the body
//
// Each kind checks its own length rule between reading the header and
// taking the body (a fixed size, or a limit), so the steps are apart:
//   read_blob_header() -> the kind's length check -> blob_body().
// Errors name the header field: "length", "magic", "version", "reserved",
// "crc".
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "piezoloop/link/crc32.hpp"
#include "piezoloop/link/wire.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

inline constexpr std::size_t kBlobHeaderBytes = 16;

// A kind of blob: its magic and layout version, and the messages that say
// what they must be (they name the kind's values, e.g. "must be 0x4D455A50
// (\"PZEM\")").
struct BlobKind {
    uint32_t magic;
    uint16_t version;
    const char* magic_rule;
    const char* version_rule;
};

struct BlobHeader {
    uint32_t magic = 0;
    uint16_t version = 0;
    uint16_t reserved = 0;
    uint32_t length = 0;  // of the body, in bytes
    uint32_t crc = 0;     // CRC-32 of the body
};

// Writes the header for `body` into the first kBlobHeaderBytes of out;
// false if out is shorter.
inline bool write_blob_header(const BlobKind& kind, std::span<const uint8_t> body, std::span<uint8_t> out) {
    if (out.size() < kBlobHeaderBytes) return false;
    link::Writer w(out.subspan(0, kBlobHeaderBytes));
    w.u32(kind.magic);
    w.u16(kind.version);
    w.u16(0);
    w.u32(static_cast<uint32_t>(body.size()));
    w.u32(link::crc32(body));
    return w.ok();
}

// True if `in` starts with `magic` (a blob of that kind is present, valid or not).
inline bool blob_present(std::span<const uint8_t> in, uint32_t magic) {
    if (in.size() < 4) return false;
    link::Reader r(in.subspan(0, 4));
    return r.u32() == magic;
}

// Reads the header at the start of `in` and checks magic, version and the
// reserved field against `kind`.
inline Status read_blob_header(std::span<const uint8_t> in, const BlobKind& kind, BlobHeader& h) {
    if (in.size() < kBlobHeaderBytes) return error("length", "shorter than the 16-byte header");
    link::Reader r(in.subspan(0, kBlobHeaderBytes));
    h.magic = r.u32();
    h.version = r.u16();
    h.reserved = r.u16();
    h.length = r.u32();
    h.crc = r.u32();
    if (h.magic != kind.magic) return error("magic", kind.magic_rule);
    if (h.version != kind.version) return error("version", kind.version_rule);
    if (h.reserved != 0) return error("reserved", "must be 0");
    return ok_status();
}

// The body the header describes (h as read_blob_header read it from `in`):
// it must lie within `in` and match the CRC.
inline Status blob_body(std::span<const uint8_t> in, const BlobHeader& h, std::span<const uint8_t>& body) {
    if (in.size() - kBlobHeaderBytes < h.length) return error("length", "body extends beyond the data");
    const std::span<const uint8_t> b = in.subspan(kBlobHeaderBytes, h.length);
    if (link::crc32(b) != h.crc) return error("crc", "CRC-32 of the body does not match the header");
    body = b;
    return ok_status();
}

}  // namespace piezoloop
