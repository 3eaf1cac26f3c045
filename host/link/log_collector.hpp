// Reassembles the recorder's LogBlocks into one record and accounts for
// everything that went wrong on the way, never silently:
//   lost_blocks     block_seq values that never arrived (a gap in block_seq)
//   out_of_order    blocks that arrived after a block with a higher block_seq
//                   (re-ordered if they come within the reorder window,
//                   otherwise their frames are dropped and they stay lost)
//   duplicates      a block_seq seen twice (the second copy is dropped)
//   tick_gaps       a block whose first tick does not follow the previous
//                   block's last frame at the stride (missing_frames counts
//                   the frames that gap spans)
//   recorder_overruns  the device's cumulative count of frames it dropped
// Tick indices are u32 on the wire and wrap; they are unwrapped by
// difference into 64-bit ticks counted from the first block.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <set>
#include <vector>

#include "piezoloop/link/messages.hpp"

namespace piezoloop::hostlink {

struct LogStats {
    uint64_t blocks = 0;           // blocks accepted into the record
    uint64_t frames = 0;           // frames in the record
    uint64_t lost_blocks = 0;
    uint64_t out_of_order = 0;
    uint64_t duplicates = 0;
    uint64_t tick_gaps = 0;
    uint64_t missing_frames = 0;   // frames inside tick gaps
    uint32_t recorder_overruns = 0;
    uint64_t inconsistent = 0;     // blocks whose channels/format/stride differ from the first (dropped)
    bool last_seen = false;        // the single-shot record's last block arrived
    bool clean() const {
        return lost_blocks == 0 && out_of_order == 0 && duplicates == 0 && tick_gaps == 0 && recorder_overruns == 0 &&
               inconsistent == 0;
    }
};

class LogCollector {
public:
    // Blocks that may wait for a missing predecessor before it is declared lost.
    explicit LogCollector(std::size_t reorder_window = 64) : window_(reorder_window) {}

    void add(const link::LogBlock& b);
    // Declares every block still missing before the waiting ones lost and
    // appends those (end of a record).
    void finish();
    void clear();

    const LogStats& stats() const { return stats_; }
    bool started() const { return have_first_; }
    std::size_t channel_count() const { return channels_; }
    const std::array<uint8_t, link::kMaxLogChannels>& channels() const { return channel_ids_; }
    link::SampleFormat format() const { return format_; }
    uint32_t stride() const { return stride_; }

    // Frame i: tick (from the first block's first tick, unwrapped) and its
    // channel_count() raw 32-bit samples.
    std::size_t size() const { return ticks_.size(); }
    uint64_t tick(std::size_t i) const { return ticks_[i]; }
    uint32_t first_tick_raw() const { return first_tick_raw_; }
    const uint32_t* raw(std::size_t i) const { return raw_.data() + i * channels_; }
    // Forgets the first `frames` frames (a live view that has taken them),
    // keeping the accounting and the tick unwrapping: later frames go on
    // from where these ended.
    void drop_front(std::size_t frames);

private:
    void append(const link::LogBlock& b);
    void declare_lost(uint32_t from, uint32_t to);

    std::size_t window_;
    LogStats stats_{};
    bool have_first_ = false;
    uint32_t next_seq_ = 0;
    uint32_t max_seq_seen_ = 0;
    bool any_seen_ = false;
    std::map<uint32_t, link::LogBlock> waiting_;
    std::set<uint32_t> declared_lost_;
    std::size_t channels_ = 0;
    std::array<uint8_t, link::kMaxLogChannels> channel_ids_{};
    link::SampleFormat format_ = link::SampleFormat::kFloat32;
    uint32_t stride_ = 1;
    uint32_t first_tick_raw_ = 0;
    bool have_prev_ = false;
    uint32_t prev_tick_raw_ = 0;   // last appended frame's tick (wire)
    uint64_t prev_tick_ = 0;       // unwrapped
    std::vector<uint64_t> ticks_;
    std::vector<uint32_t> raw_;
};

}  // namespace piezoloop::hostlink
