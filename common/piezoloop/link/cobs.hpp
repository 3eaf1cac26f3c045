// Consistent Overhead Byte Stuffing (Cheshire and Baker, 1999): rewrites a
// packet so that it contains no 0x00 byte, so 0x00 can delimit frames on a
// byte stream and a receiver resynchronises at the next 0x00 after any
// garbage. Each run of up to 254 non-zero bytes is preceded by a code byte
// (run length + 1); code 0xFF means a full run with no zero after it.
// Overhead: at most one byte per 254 bytes, plus one.
//
// Both functions work on caller-provided buffers and never write past them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace piezoloop::link {

// Largest encoded size of n bytes (without the 0x00 delimiter).
constexpr std::size_t cobs_max_encoded_size(std::size_t n) { return n + n / 254u + 1u; }

// Encodes in into out (no delimiter). Returns the encoded length, or 0 if out
// is too small (an encoding is never empty: it has at least one code byte).
constexpr std::size_t cobs_encode(std::span<const uint8_t> in, std::span<uint8_t> out) {
    if (out.empty()) return 0;
    std::size_t code_at = 0;  // where the current run's code byte goes
    std::size_t w = 1;
    uint8_t code = 1;
    for (std::size_t i = 0; i < in.size(); ++i) {
        if (in[i] == 0) {
            out[code_at] = code;
            code_at = w;
            if (w >= out.size()) return 0;
            ++w;
            code = 1;
            continue;
        }
        if (w >= out.size()) return 0;
        out[w++] = in[i];
        ++code;
        if (code == 0xFF) {
            out[code_at] = code;
            code_at = w;
            // A full run at the very end needs no further code byte.
            if (i + 1 == in.size()) return w;
            if (w >= out.size()) return 0;
            ++w;
            code = 1;
        }
    }
    out[code_at] = code;
    return w;
}

enum class CobsError : uint8_t {
    kOk = 0,
    kZeroInFrame,  // a 0x00 inside the encoded frame (the delimiter belongs outside)
    kOverrun,      // a code byte announces more bytes than the frame holds
    kNoSpace,      // the output buffer is too small
};

struct CobsResult {
    std::size_t size = 0;
    CobsError error = CobsError::kOk;
};

// Decodes in (one frame without its delimiter) into out. out may alias in
// (decoding never writes ahead of reading), so frames can be decoded in place.
constexpr CobsResult cobs_decode(std::span<const uint8_t> in, std::span<uint8_t> out) {
    std::size_t r = 0, w = 0;
    while (r < in.size()) {
        const uint8_t code = in[r++];
        if (code == 0) return {w, CobsError::kZeroInFrame};
        const std::size_t run = static_cast<std::size_t>(code) - 1u;
        if (run > in.size() - r) return {w, CobsError::kOverrun};
        for (std::size_t k = 0; k < run; ++k) {
            const uint8_t b = in[r++];
            if (b == 0) return {w, CobsError::kZeroInFrame};
            if (w >= out.size()) return {w, CobsError::kNoSpace};
            out[w++] = b;
        }
        // The implied zero after a short run, except after the last run.
        if (code != 0xFF && r < in.size()) {
            if (w >= out.size()) return {w, CobsError::kNoSpace};
            out[w++] = 0;
        }
    }
    return {w, CobsError::kOk};
}

}  // namespace piezoloop::link
