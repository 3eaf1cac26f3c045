// The log stream of the link: reads the recorder's frames in the main loop
// and sends them as LogBlocks. A block is sent when it is full, when the
// next frame does not follow at the decimation stride (a gap: an overrun or
// the trigger), or when the recorder has stopped and the frames read so far
// are the last ones.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

#include "piezoloop/link/messages.hpp"

namespace piezoloop::link {

template <class T, class Recorder, std::size_t Channels>
class LogStream {
    static_assert(Channels >= 1 && Channels <= kMaxLogChannels, "log blocks carry up to 8 channels");

public:
    static constexpr std::size_t kFramesPerBlock = log_frames_per_block(Channels);

    // A new record: block numbering from 0, nothing pending.
    void restart() {
        seq_ = 0;
        blocks_ = 0;
        pending_ = 0;
    }
    // The recorder was reconfigured: frames read under the old setting are dropped.
    void drop_pending() { pending_ = 0; }

    uint32_t blocks_sent() const { return blocks_; }

    // Sends at most one block through send(std::span<const uint8_t>); true if it did.
    template <class Send>
    bool poll(Recorder& rec, std::span<uint8_t> tx, Send&& send) {
        if (pending_ < kFramesPerBlock)
            pending_ += rec.read(std::span<typename Recorder::Frame>(frames_.data() + pending_, kFramesPerBlock - pending_));
        if (pending_ == 0) return false;
        const uint32_t stride = rec.config().decimation;
        std::size_t n = 1;
        while (n < pending_ && frames_[n].tick - frames_[n - 1].tick == stride) ++n;
        const RecorderState st = rec.state();
        const bool stopped = st == RecorderState::kIdle || st == RecorderState::kDone;
        const bool last = stopped && n == pending_ && rec.available() == 0;
        if (n == pending_ && pending_ < kFramesPerBlock && !last) return false;

        LogBlock b;
        b.block_seq = seq_;
        b.first_tick = frames_[0].tick;
        b.tick_stride = stride;
        b.recorder_overruns = rec.overruns();
        b.channel_count = static_cast<uint8_t>(Channels);
        b.format = std::is_same_v<T, float> ? SampleFormat::kFloat32 : SampleFormat::kQ31;
        b.frame_count = static_cast<uint8_t>(n);
        b.flags = (last && st == RecorderState::kDone) ? LogBlock::kFlagLast : 0;
        // The recorder's signal index, axis * kSignalCount + signal (link/board_policy.hpp).
        for (std::size_t c = 0; c < Channels; ++c) b.channels[c] = rec.config().channels[c];
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t c = 0; c < Channels; ++c) b.samples[i * Channels + c] = sample_bits(frames_[i].value[c]);
        const std::size_t len = encode_message(b, 0, tx);
        if (len == 0) return false;  // cannot happen: a full block fits kMaxPayload
        send(std::span<const uint8_t>(tx.data(), len));
        ++seq_;
        LinkCounters::inc(blocks_);
        for (std::size_t i = n; i < pending_; ++i) frames_[i - n] = frames_[i];
        pending_ -= n;
        return true;
    }

private:
    static uint32_t sample_bits(T v) {
        if constexpr (std::is_same_v<T, float>) return std::bit_cast<uint32_t>(v); else return static_cast<uint32_t>(v.raw());
    }

    std::array<typename Recorder::Frame, kFramesPerBlock> frames_{};
    std::size_t pending_ = 0;
    uint32_t seq_ = 0;
    uint32_t blocks_ = 0;
};

}  // namespace piezoloop::link
