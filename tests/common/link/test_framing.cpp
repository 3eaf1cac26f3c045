// CRC-32, COBS and the streaming frame decoder against independent references:
// the CRC-32 check value of the CRC catalogue and a bit-serial implementation
// of the polynomial division, COBS against the worked examples of its
// definition (Cheshire & Baker 1999, as tabulated in the literature).
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string_view>
#include <vector>

#include "piezoloop/link/cobs.hpp"
#include "piezoloop/link/crc32.hpp"
#include "piezoloop/link/framing.hpp"

using namespace piezoloop::link;

namespace {

std::span<const uint8_t> bytes(std::string_view s) {
    return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

// Bit-serial CRC-32: shift register, MSB-first on the bit-reversed data,
// i.e. the textbook polynomial division by 0x04C11DB7 with reflected I/O.
uint32_t reflect(uint32_t v, int bits) {
    uint32_t r = 0;
    for (int i = 0; i < bits; ++i) if (v & (1u << i)) r |= 1u << (bits - 1 - i);
    return r;
}
uint32_t crc32_bitwise(std::span<const uint8_t> d) {
    uint32_t reg = 0xFFFFFFFFu;
    for (uint8_t b : d) {
        reg ^= reflect(b, 8) << 24;
        for (int k = 0; k < 8; ++k) reg = (reg & 0x80000000u) ? (reg << 1) ^ 0x04C11DB7u : reg << 1;
    }
    return reflect(reg, 32) ^ 0xFFFFFFFFu;
}

std::vector<uint8_t> cobs(const std::vector<uint8_t>& in) {
    std::vector<uint8_t> out(cobs_max_encoded_size(in.size()));
    const std::size_t n = cobs_encode(in, out);
    EXPECT_GT(n, 0u);
    out.resize(n);
    return out;
}

std::vector<uint8_t> seq_bytes(int from, int to) {  // inclusive
    std::vector<uint8_t> v;
    for (int i = from; i <= to; ++i) v.push_back(static_cast<uint8_t>(i));
    return v;
}

}  // namespace

TEST(LinkCrc32, CheckValue) {
    // CRC catalogue "CRC-32/ISO-HDLC" check value; exact (integer arithmetic).
    EXPECT_EQ(crc32(bytes("123456789")), 0xCBF43926u);
    static_assert(crc32(std::span<const uint8_t>()) == 0u);
    EXPECT_EQ(crc32(bytes("The quick brown fox jumps over the lazy dog")), 0x414FA339u);  // zlib.crc32
}

TEST(LinkCrc32, MatchesBitSerialDivision) {
    std::mt19937 rng(1);
    for (int t = 0; t < 2000; ++t) {
        std::vector<uint8_t> d(rng() % 600);
        for (auto& b : d) b = static_cast<uint8_t>(rng());
        ASSERT_EQ(crc32(d), crc32_bitwise(d)) << "length " << d.size();
        // Incremental in two parts equals one pass.
        const std::size_t cut = d.empty() ? 0 : rng() % d.size();
        const uint32_t st = crc32_update(0xFFFFFFFFu, std::span<const uint8_t>(d).first(cut));
        ASSERT_EQ(crc32_update(st, std::span<const uint8_t>(d).subspan(cut)) ^ 0xFFFFFFFFu, crc32(d));
    }
}

TEST(LinkCobs, WorkedExamples) {
    using V = std::vector<uint8_t>;
    EXPECT_EQ(cobs(V{}), (V{0x01}));
    EXPECT_EQ(cobs(V{0x00}), (V{0x01, 0x01}));
    EXPECT_EQ(cobs(V{0x00, 0x00}), (V{0x01, 0x01, 0x01}));
    EXPECT_EQ(cobs(V{0x00, 0x11, 0x00}), (V{0x01, 0x02, 0x11, 0x01}));
    EXPECT_EQ(cobs(V{0x11, 0x22, 0x00, 0x33}), (V{0x03, 0x11, 0x22, 0x02, 0x33}));
    EXPECT_EQ(cobs(V{0x11, 0x22, 0x33, 0x44}), (V{0x05, 0x11, 0x22, 0x33, 0x44}));
    EXPECT_EQ(cobs(V{0x11, 0x00, 0x00, 0x00}), (V{0x02, 0x11, 0x01, 0x01, 0x01}));
    // 01..FE (254 bytes): one full run, no trailing code.
    V e = seq_bytes(1, 254);
    e.insert(e.begin(), 0xFF);
    EXPECT_EQ(cobs(seq_bytes(1, 254)), e);
    // 00 01..FE (255 bytes) -> 01 FF 01..FE
    V in = seq_bytes(0, 254);
    e = seq_bytes(1, 254);
    e.insert(e.begin(), {0x01, 0xFF});
    EXPECT_EQ(cobs(in), e);
    // 01..FF (255 bytes) -> FF 01..FE 02 FF
    e = seq_bytes(1, 254);
    e.insert(e.begin(), 0xFF);
    e.insert(e.end(), {0x02, 0xFF});
    EXPECT_EQ(cobs(seq_bytes(1, 255)), e);
    // 02..FF 00 (255 bytes) -> FF 02..FF 01 01
    in = seq_bytes(2, 255);
    in.push_back(0);
    e = seq_bytes(2, 255);
    e.insert(e.begin(), 0xFF);
    e.insert(e.end(), {0x01, 0x01});
    EXPECT_EQ(cobs(in), e);
    // 03..FF 00 01 (255 bytes) -> FE 03..FF 02 01
    in = seq_bytes(3, 255);
    in.insert(in.end(), {0x00, 0x01});
    e = seq_bytes(3, 255);
    e.insert(e.begin(), 0xFE);
    e.insert(e.end(), {0x02, 0x01});
    EXPECT_EQ(cobs(in), e);
}

TEST(LinkCobs, RoundTripRandomAndBounds) {
    std::mt19937 rng(2);
    for (int t = 0; t < 5000; ++t) {
        std::vector<uint8_t> d(rng() % 1100);
        const int zero_share = static_cast<int>(rng() % 4);  // from no zeros to many
        for (auto& b : d) b = (static_cast<int>(rng() % 8) < zero_share) ? 0 : static_cast<uint8_t>(1 + rng() % 255);
        const auto enc = cobs(d);
        ASSERT_LE(enc.size(), cobs_max_encoded_size(d.size()));
        for (uint8_t b : enc) ASSERT_NE(b, 0);
        std::vector<uint8_t> dec(d.size() + 1);
        const CobsResult r = cobs_decode(enc, dec);
        ASSERT_EQ(r.error, CobsError::kOk);
        dec.resize(r.size);
        ASSERT_EQ(dec, d);
        // An output buffer one byte short is refused, never overrun.
        if (!enc.empty()) {
            std::vector<uint8_t> small(enc.size() - 1 + 8, 0xAA);
            EXPECT_EQ(cobs_encode(d, std::span<uint8_t>(small).first(enc.size() - 1)), 0u);
            for (std::size_t i = enc.size() - 1; i < small.size(); ++i) ASSERT_EQ(small[i], 0xAA);
        }
    }
}

TEST(LinkCobs, DecodeRejects) {
    std::vector<uint8_t> out(16);
    const std::vector<uint8_t> overrun{0x05, 0x11, 0x22};
    EXPECT_EQ(cobs_decode(overrun, out).error, CobsError::kOverrun);
    const std::vector<uint8_t> zero{0x03, 0x11, 0x00};
    EXPECT_EQ(cobs_decode(zero, out).error, CobsError::kZeroInFrame);
    const std::vector<uint8_t> big{0x05, 1, 2, 3, 4};
    EXPECT_EQ(cobs_decode(big, std::span<uint8_t>(out).first(3)).error, CobsError::kNoSpace);
}

namespace {

std::vector<uint8_t> make_frame(uint8_t type, uint16_t seq, const std::vector<uint8_t>& body) {
    std::vector<uint8_t> f(kMaxFrameSize);
    const std::size_t n = encode_frame(type, 1, seq, body, f);
    EXPECT_GT(n, 0u);
    f.resize(n);
    return f;
}

struct Collector {
    std::vector<std::vector<uint8_t>> payloads;
    auto fn() {
        return [this](std::span<const uint8_t> p) { payloads.emplace_back(p.begin(), p.end()); };
    }
};

}  // namespace

TEST(LinkFrameDecoder, ArbitraryChunksAndIdleFill) {
    std::mt19937 rng(3);
    std::vector<uint8_t> stream{0, 0};
    std::vector<std::vector<uint8_t>> sent;
    for (int i = 0; i < 200; ++i) {
        std::vector<uint8_t> body(rng() % (kMaxBody + 1));
        for (auto& b : body) b = static_cast<uint8_t>(rng() % 3 == 0 ? 0 : rng());
        const auto f = make_frame(static_cast<uint8_t>(1 + rng() % 14), static_cast<uint16_t>(i), body);
        stream.insert(stream.end(), f.begin(), f.end());
        if (rng() % 4 == 0) stream.push_back(0);  // idle fill between frames
        sent.push_back(body);
    }
    FrameDecoder dec;
    Collector c;
    std::size_t at = 0;
    while (at < stream.size()) {
        const std::size_t n = std::min<std::size_t>(1 + rng() % 700, stream.size() - at);
        dec.feed(std::span<const uint8_t>(stream).subspan(at, n), c.fn());
        at += n;
    }
    ASSERT_EQ(c.payloads.size(), sent.size());
    for (std::size_t i = 0; i < sent.size(); ++i) {
        const FrameHeader h = parse_header(c.payloads[i]);
        EXPECT_EQ(h.seq, i);
        EXPECT_EQ(std::vector<uint8_t>(c.payloads[i].begin() + kHeaderSize, c.payloads[i].end()), sent[i]);
    }
    EXPECT_EQ(dec.counters().frames_ok, sent.size());
    EXPECT_EQ(dec.counters().dropped(), 0u);
}

TEST(LinkFrameDecoder, CountsEveryMalformedFrameAndResynchronises) {
    const auto good = make_frame(0x02, 7, {});
    FrameDecoder dec;
    Collector c;
    auto feed = [&](const std::vector<uint8_t>& v) { dec.feed(v, c.fn()); };

    // Garbage without a delimiter, then a delimiter: one bad frame (COBS or
    // CRC), and the next good frame arrives.
    std::vector<uint8_t> bad_crc = good;
    bad_crc[2] ^= 0x01;  // a payload byte: CRC mismatch (still no zero byte)
    if (bad_crc[2] == 0) bad_crc[2] = 0x55;
    feed(bad_crc);
    EXPECT_EQ(dec.counters().bad_crc, 1u);

    feed({0x09, 0x11, 0x22, 0x00});  // code 9 announces 8 bytes, 2 present
    EXPECT_EQ(dec.counters().bad_cobs, 1u);

    feed({0x03, 0x11, 0x22, 0x00});  // decodes to 2 bytes: shorter than header + CRC
    EXPECT_EQ(dec.counters().truncated, 1u);

    std::vector<uint8_t> huge(2000, 0x42);
    huge.push_back(0);
    feed(huge);
    EXPECT_EQ(dec.counters().oversize, 1u);

    // A frame cut short by a lost tail: CRC (or COBS) fails.
    const auto longer = make_frame(0x04, 8, std::vector<uint8_t>(40, 0x33));
    std::vector<uint8_t> cut(longer.begin(), longer.end() - 3);
    cut.push_back(0);
    feed(cut);
    EXPECT_EQ(dec.counters().bad_crc + dec.counters().bad_cobs, 3u);

    EXPECT_TRUE(c.payloads.empty());
    feed(good);
    ASSERT_EQ(c.payloads.size(), 1u);
    EXPECT_EQ(parse_header(c.payloads[0]).seq, 7);
    EXPECT_EQ(dec.counters().frames_ok, 1u);
    EXPECT_EQ(dec.counters().dropped(), 5u);
}

TEST(LinkFrameDecoder, LargestFrameFitsAndOneMoreIsOversize) {
    std::vector<uint8_t> body(kMaxBody, 0x7F);  // no zeros: the largest COBS overhead
    const auto f = make_frame(0x04, 1, body);
    EXPECT_EQ(f.size(), kMaxFrameSize);
    FrameDecoder dec;
    Collector c;
    dec.feed(f, c.fn());
    EXPECT_EQ(c.payloads.size(), 1u);
    std::vector<uint8_t> too_big(kMaxBody + 1, 0x7F), out(kMaxFrameSize + 8);
    EXPECT_EQ(encode_frame(0x04, 1, 1, too_big, out), 0u);
}
