// Little-endian field access on byte buffers, for the fixed message layouts.
// Writer and Reader never touch memory outside their span: an access that
// does not fit sets a sticky failure flag instead (checked once at the end),
// so a message codec reads like its layout table with no check per field.
// Floats travel as their IEEE-754 bit patterns (bit_cast), so NaN and
// infinities arrive as sent and are rejected by the validation that follows,
// never by the codec.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>

namespace piezoloop::link {

class Writer {
public:
    constexpr explicit Writer(std::span<uint8_t> buf) : buf_(buf) {}

    constexpr void u8(uint8_t v) { put(v, 1); }
    constexpr void u16(uint16_t v) { put(v, 2); }
    constexpr void u32(uint32_t v) { put(v, 4); }
    constexpr void u64(uint64_t v) { put(v, 8); }
    constexpr void i16(int16_t v) { put(static_cast<uint16_t>(v), 2); }
    constexpr void i32(int32_t v) { put(static_cast<uint32_t>(v), 4); }
    constexpr void f32(float v) { put(std::bit_cast<uint32_t>(v), 4); }
    constexpr void f64(double v) { put(std::bit_cast<uint64_t>(v), 8); }
    constexpr void boolean(bool v) { u8(v ? 1 : 0); }
    // A fixed-size text field: the string, then zero padding; a longer
    // string is cut so that at least one terminating zero remains.
    constexpr void text(const char* s, std::size_t field_size) {
        std::size_t i = 0;
        if (s != nullptr)
            for (; i + 1 < field_size && s[i] != '\0'; ++i) u8(static_cast<uint8_t>(s[i]));
        for (; i < field_size; ++i) u8(0);
    }

    constexpr bool ok() const { return ok_; }
    constexpr std::size_t size() const { return n_; }

private:
    constexpr void put(uint64_t v, std::size_t bytes) {
        if (!ok_ || buf_.size() - n_ < bytes) { ok_ = false; return; }
        for (std::size_t i = 0; i < bytes; ++i) buf_[n_++] = static_cast<uint8_t>(v >> (8 * i));
    }
    std::span<uint8_t> buf_;
    std::size_t n_ = 0;
    bool ok_ = true;
};

class Reader {
public:
    constexpr explicit Reader(std::span<const uint8_t> buf) : buf_(buf) {}

    constexpr uint8_t u8() { return static_cast<uint8_t>(get(1)); }
    constexpr uint16_t u16() { return static_cast<uint16_t>(get(2)); }
    constexpr uint32_t u32() { return static_cast<uint32_t>(get(4)); }
    constexpr uint64_t u64() { return get(8); }
    constexpr int16_t i16() { return static_cast<int16_t>(u16()); }
    constexpr int32_t i32() { return static_cast<int32_t>(u32()); }
    constexpr float f32() { return std::bit_cast<float>(u32()); }
    constexpr double f64() { return std::bit_cast<double>(u64()); }
    // Booleans are 0 or 1; anything else marks the message malformed.
    constexpr bool boolean() {
        const uint8_t v = u8();
        if (v > 1) bad_value_ = true;
        return v == 1;
    }
    // Copies a fixed-size text field into out (zero-terminated, out_size >= 1).
    constexpr void text(char* out, std::size_t out_size, std::size_t field_size) {
        for (std::size_t i = 0; i < field_size; ++i) {
            const uint8_t c = u8();
            if (i < out_size) out[i] = static_cast<char>(c);
        }
        if (out_size > 0) out[(field_size < out_size ? field_size : out_size) - 1] = '\0';
    }

    // Every field was present.
    constexpr bool ok() const { return ok_; }
    // Every field was present, well-formed, and nothing is left over.
    constexpr bool complete() const { return ok_ && !bad_value_ && n_ == buf_.size(); }
    constexpr bool bad_value() const { return bad_value_; }
    constexpr void mark_bad() { bad_value_ = true; }
    constexpr std::size_t remaining() const { return buf_.size() - n_; }
    constexpr std::size_t position() const { return n_; }

private:
    constexpr uint64_t get(std::size_t bytes) {
        if (!ok_ || buf_.size() - n_ < bytes) { ok_ = false; return 0; }
        uint64_t v = 0;
        for (std::size_t i = 0; i < bytes; ++i) v |= uint64_t{buf_[n_++]} << (8 * i);
        return v;
    }
    std::span<const uint8_t> buf_;
    std::size_t n_ = 0;
    bool ok_ = true;
    bool bad_value_ = false;
};

}  // namespace piezoloop::link
