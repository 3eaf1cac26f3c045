#include "link/log_collector.hpp"

#include <algorithm>

namespace piezoloop::hostlink {

void LogCollector::clear() { *this = LogCollector(window_); }

void LogCollector::add(const link::LogBlock& b) {
    const uint32_t seq = b.block_seq;
    if (waiting_.count(seq) != 0 || (seq < next_seq_ && declared_lost_.count(seq) == 0)) {
        ++stats_.duplicates;  // a second copy of a block already held or appended
        return;
    }
    if (any_seen_ && seq < max_seq_seen_) ++stats_.out_of_order;
    if (!any_seen_ || seq > max_seq_seen_) max_seq_seen_ = seq;
    any_seen_ = true;
    if (seq < next_seq_) return;  // late: declared lost already (and counted out of order above)
    waiting_.emplace(seq, b);
    // Append everything contiguous; give up on a gap once the window is full.
    for (;;) {
        auto it = waiting_.find(next_seq_);
        if (it != waiting_.end()) {
            append(it->second);
            waiting_.erase(it);
            ++next_seq_;
            continue;
        }
        if (waiting_.size() > window_) {
            const uint32_t first = waiting_.begin()->first;
            declare_lost(next_seq_, first);
            next_seq_ = first;
            continue;
        }
        break;
    }
}

void LogCollector::drop_front(std::size_t frames) {
    frames = std::min(frames, ticks_.size());
    ticks_.erase(ticks_.begin(), ticks_.begin() + static_cast<std::ptrdiff_t>(frames));
    raw_.erase(raw_.begin(), raw_.begin() + static_cast<std::ptrdiff_t>(frames * channels_));
}

void LogCollector::finish() {
    while (!waiting_.empty()) {
        const uint32_t first = waiting_.begin()->first;
        declare_lost(next_seq_, first);
        append(waiting_.begin()->second);
        waiting_.erase(waiting_.begin());
        next_seq_ = first + 1;
    }
}

void LogCollector::declare_lost(uint32_t from, uint32_t to) {
    stats_.lost_blocks += to - from;
    for (uint32_t s = from; s != to && declared_lost_.size() < 100000; ++s) declared_lost_.insert(s);
}

void LogCollector::append(const link::LogBlock& b) {
    if (!have_first_) {
        have_first_ = true;
        channels_ = b.channel_count;
        channel_ids_ = b.channels;
        format_ = b.format;
        stride_ = b.tick_stride == 0 ? 1 : b.tick_stride;
        first_tick_raw_ = b.first_tick;
    } else if (b.channel_count != channels_ || b.format != format_ || b.tick_stride != stride_ ||
               b.channels != channel_ids_) {
        ++stats_.inconsistent;
        return;
    }
    if (b.recorder_overruns > stats_.recorder_overruns) stats_.recorder_overruns = b.recorder_overruns;
    if (b.flags & link::LogBlock::kFlagLast) stats_.last_seen = true;
    ++stats_.blocks;
    if (b.frame_count == 0) return;
    uint64_t t0 = 0;
    if (!have_prev_) {
        t0 = 0;
    } else {
        // Difference on the wire's u32 ticks unwraps the 32-bit counter.
        const uint32_t expected = prev_tick_raw_ + stride_;
        const uint32_t d = b.first_tick - expected;
        if (d != 0) {
            ++stats_.tick_gaps;
            if (static_cast<int32_t>(d) > 0) stats_.missing_frames += d / stride_;
        }
        t0 = prev_tick_ + stride_ + static_cast<uint64_t>(static_cast<int64_t>(static_cast<int32_t>(d)));
    }
    for (std::size_t i = 0; i < b.frame_count; ++i) {
        ticks_.push_back(t0 + i * stride_);
        for (std::size_t c = 0; c < channels_; ++c) raw_.push_back(b.samples[i * channels_ + c]);
    }
    have_prev_ = true;
    prev_tick_raw_ = b.first_tick + static_cast<uint32_t>(b.frame_count - 1) * stride_;
    prev_tick_ = t0 + static_cast<uint64_t>(b.frame_count - 1) * stride_;
    stats_.frames += b.frame_count;  // all frames taken, also those dropped since
}

}  // namespace piezoloop::hostlink
