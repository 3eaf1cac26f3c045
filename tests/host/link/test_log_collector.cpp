// LogCollector (host/link/log_collector) on hand-made blocks: the u32 tick
// wrap, lost, duplicate and late blocks, and drop_front, what a live view
// uses to keep memory bounded: the frames it has taken are forgotten, the
// ticks of later frames go on unwrapped from where they were, and the
// accounting still counts every frame and every gap.
#include <gtest/gtest.h>

#include "link/log_collector.hpp"

namespace piezoloop::hostlink {
namespace {

link::LogBlock block(uint32_t seq, uint32_t first_tick, uint8_t frames) {
    link::LogBlock b;
    b.block_seq = seq;
    b.first_tick = first_tick;
    b.tick_stride = 1;
    b.channel_count = 1;
    b.frame_count = frames;
    for (uint8_t i = 0; i < frames; ++i) b.samples[i] = first_tick + i;
    return b;
}

TEST(HostLinkLogCollector, UnwrapsTheTickCounter) {
    LogCollector l;
    l.add(block(0, 0xffffff00u, 120));
    l.add(block(1, 0xffffff00u + 120, 120));
    l.add(block(2, 0xffffff00u + 240, 120));  // crosses 2^32
    l.finish();
    EXPECT_TRUE(l.stats().clean());
    ASSERT_EQ(l.size(), 360u);
    for (std::size_t i = 0; i < l.size(); ++i) {
        ASSERT_EQ(l.tick(i), i);
        ASSERT_EQ(l.raw(i)[0], 0xffffff00u + static_cast<uint32_t>(i));
    }
}

TEST(HostLinkLogCollector, DuplicateAndLateBlocksAreCounted) {
    LogCollector l(2);
    l.add(block(0, 0, 10));
    l.add(block(0, 0, 10));          // duplicate
    l.add(block(2, 20, 10));
    l.add(block(3, 30, 10));
    l.add(block(4, 40, 10));          // window of 2 exceeded: block 1 declared lost
    l.add(block(1, 10, 10));          // late: stays lost, counted out of order
    l.finish();
    EXPECT_EQ(l.stats().duplicates, 1u);
    EXPECT_EQ(l.stats().lost_blocks, 1u);
    EXPECT_EQ(l.stats().out_of_order, 1u);
    EXPECT_EQ(l.stats().tick_gaps, 1u);
    EXPECT_EQ(l.stats().missing_frames, 10u);
    EXPECT_EQ(l.size(), 40u);
}

TEST(HostLinkLogCollectorDrop, LaterFramesGoOnFromTheDroppedOnes) {
    LogCollector l;
    const uint32_t start = 0xffffff00u;
    l.add(block(0, start, 120));
    l.add(block(1, start + 120, 120));
    ASSERT_EQ(l.size(), 240u);
    l.drop_front(200);
    ASSERT_EQ(l.size(), 40u);
    EXPECT_EQ(l.tick(0), 200u);
    EXPECT_EQ(l.raw(0)[0], start + 200);
    l.drop_front(l.size());
    EXPECT_EQ(l.size(), 0u);
    l.add(block(2, start + 240, 120));  // crosses 2^32
    l.add(block(4, start + 480, 120));  // block 3 missing: a gap of 120 ticks
    l.finish();
    ASSERT_EQ(l.size(), 240u);
    for (std::size_t i = 0; i < 120; ++i) ASSERT_EQ(l.tick(i), 240u + i);
    EXPECT_EQ(l.tick(120), 480u);
    EXPECT_EQ(l.stats().frames, 480u);  // all taken, dropped or not
    EXPECT_EQ(l.stats().lost_blocks, 1u);
    EXPECT_EQ(l.stats().tick_gaps, 1u);
    EXPECT_EQ(l.stats().missing_frames, 120u);
}

TEST(HostLinkLogCollectorDrop, DroppingMoreThanHeldEmptiesIt) {
    LogCollector l;
    l.add(block(0, 0, 10));
    l.drop_front(50);
    EXPECT_EQ(l.size(), 0u);
    l.add(block(1, 10, 10));
    ASSERT_EQ(l.size(), 10u);
    EXPECT_EQ(l.tick(0), 10u);
}

}  // namespace
}  // namespace piezoloop::hostlink
