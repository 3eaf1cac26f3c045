// The USB driver's byte ring (firmware/usb/byte_ring.hpp): FIFO order,
// capacity limits, wrap of the buffer index and of the uint32 counters, and
// a seeded random interleaving checked against std::deque. Exact (bytes).
#include <gtest/gtest.h>

#include <cstdint>
#include <deque>
#include <random>
#include <vector>

#include "usb/byte_ring.hpp"

using piezoloop::usb::ByteRing;

TEST(UsbByteRing, FifoOrderAndLimits) {
    ByteRing<8> r;
    EXPECT_EQ(r.available(), 0u);
    EXPECT_EQ(r.free_space(), 8u);
    const uint8_t a[5] = {1, 2, 3, 4, 5};
    EXPECT_EQ(r.write(a, 5), 5u);
    EXPECT_EQ(r.write(a, 5), 3u) << "only what fits is taken";
    EXPECT_EQ(r.free_space(), 0u);
    uint8_t out[16] = {};
    EXPECT_EQ(r.read(out, 16), 8u);
    const uint8_t want[8] = {1, 2, 3, 4, 5, 1, 2, 3};
    for (int i = 0; i < 8; ++i) EXPECT_EQ(out[i], want[i]) << i;
    EXPECT_EQ(r.read(out, 16), 0u);
}

TEST(UsbByteRing, WrapsBufferAndCounters) {
    // Counters start 3 bytes before 2^32: the first writes cross the wrap.
    ByteRing<4> r(0xFFFFFFFDu);
    uint8_t next_in = 0, next_out = 0;
    for (int round = 0; round < 20; ++round) {
        uint8_t chunk[3] = {next_in, static_cast<uint8_t>(next_in + 1), static_cast<uint8_t>(next_in + 2)};
        ASSERT_EQ(r.write(chunk, 3), 3u);
        next_in = static_cast<uint8_t>(next_in + 3);
        uint8_t out[3];
        ASSERT_EQ(r.read(out, 3), 3u);
        for (uint8_t b : out) EXPECT_EQ(b, next_out++);
        EXPECT_EQ(r.available(), 0u);
        EXPECT_EQ(r.free_space(), 4u);
    }
}

TEST(UsbByteRing, MatchesADequeUnderRandomTraffic) {
    std::mt19937 rng(12345);  // seeded: reproducible
    ByteRing<64> r(0xFFFFFF00u);
    std::deque<uint8_t> model;
    uint8_t counter = 0;
    for (int step = 0; step < 20000; ++step) {
        if (rng() % 2 == 0) {
            std::vector<uint8_t> data(rng() % 40);
            for (auto& b : data) b = counter++;
            const std::size_t took = r.write(data.data(), data.size());
            const std::size_t room = 64 - model.size();
            ASSERT_EQ(took, data.size() < room ? data.size() : room);
            model.insert(model.end(), data.begin(), data.begin() + static_cast<std::ptrdiff_t>(took));
            counter = static_cast<uint8_t>(counter - (data.size() - took));  // untaken bytes are re-offered
        } else {
            std::vector<uint8_t> out(rng() % 40);
            const std::size_t got = r.read(out.data(), out.size());
            ASSERT_EQ(got, out.size() < model.size() ? out.size() : model.size());
            for (std::size_t i = 0; i < got; ++i) {
                ASSERT_EQ(out[i], model.front());
                model.pop_front();
            }
        }
        ASSERT_EQ(r.available(), model.size());
    }
}
