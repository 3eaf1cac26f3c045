// Recorder: selection, decimation, triggers with pre-trigger history,
// ordering across wrap-around, overrun accounting, and a real two-thread
// producer/consumer run. Signals are synthetic (each value encodes its tick
// and signal index) so every frame can be checked exactly.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <thread>
#include <vector>

#include "piezoloop/recorder.hpp"

using piezoloop::Q31;
using piezoloop::RecordMode;
using piezoloop::RecorderState;
using piezoloop::SignalId;
using piezoloop::SignalScale;
using piezoloop::TriggerMode;
using piezoloop::signal_index;

namespace {

constexpr std::size_t kSig = piezoloop::kSignalCount;
using Vec = std::array<float, kSig>;

// Signal s at tick t: 1000 * s + t (exact in float for t < 2^23 / ... small tests).
Vec signals_at(uint32_t t) {
    Vec v{};
    for (std::size_t s = 0; s < kSig; ++s) v[s] = static_cast<float>(1000 * s + (t % 1000));
    return v;
}

template <class R>
std::vector<typename R::Frame> drain(R& rec) {
    std::vector<typename R::Frame> out;
    std::array<typename R::Frame, 5> buf{};  // small chunks: exercises partial reads
    for (;;) {
        const std::size_t n = rec.read(buf);
        if (n == 0) break;
        out.insert(out.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
    }
    return out;
}

}  // namespace

TEST(Recorder, SignalNames) {
    EXPECT_STREQ(piezoloop::signal_name(SignalId::kR), "r");
    EXPECT_STREQ(piezoloop::signal_name(SignalId::kUrc), "u_rc");
    EXPECT_STREQ(piezoloop::signal_name(SignalId::kD), "d");
    EXPECT_EQ(kSig, 8u);
}

TEST(Recorder, ImmediateSingleShotWithSelectionAndDecimation) {
    piezoloop::Recorder<float, 2, 64> rec;
    piezoloop::RecorderConfig<2> c;
    c.channels = {signal_index(SignalId::kE), signal_index(SignalId::kR)};
    c.decimation = 3;
    c.length = 10;
    ASSERT_TRUE(rec.configure(c).ok());
    EXPECT_EQ(rec.state(), RecorderState::kIdle);
    for (uint32_t t = 0; t < 5; ++t) rec.push(t, signals_at(t));  // idle: ignored
    EXPECT_EQ(rec.available(), 0u);

    ASSERT_TRUE(rec.arm());
    EXPECT_EQ(rec.state(), RecorderState::kArmed);
    for (uint32_t t = 100; t < 200; ++t) rec.push(t, signals_at(t));
    EXPECT_EQ(rec.state(), RecorderState::kDone);
    EXPECT_EQ(rec.trigger_tick(), 100u);
    const auto f = drain(rec);
    ASSERT_EQ(f.size(), 10u);
    for (std::size_t i = 0; i < f.size(); ++i) {
        const uint32_t t = 100 + 3 * static_cast<uint32_t>(i);  // every 3rd tick from the trigger
        EXPECT_EQ(f[i].tick, t);
        EXPECT_EQ(f[i].value[0], signals_at(t)[signal_index(SignalId::kE)]);
        EXPECT_EQ(f[i].value[1], signals_at(t)[signal_index(SignalId::kR)]);
    }
    EXPECT_EQ(rec.overruns(), 0u);
}

TEST(Recorder, RisingTriggerWithPreTrigger) {
    piezoloop::Recorder<float, 1, 32> rec;
    piezoloop::RecorderConfig<1> c;
    c.channels = {signal_index(SignalId::kY)};
    c.decimation = 2;
    c.trigger = TriggerMode::kRising;
    c.trigger_signal = signal_index(SignalId::kR);
    c.trigger_level = 0.5f;
    c.pre_trigger = 4;
    c.length = 12;
    ASSERT_TRUE(rec.configure(c).ok());
    ASSERT_TRUE(rec.arm());

    // r: a square wave of period 40 ticks (0 for 20, 1 for 20), rising at
    // t = 20, 60, 100 ... The first crossing comes after 10 kept ticks at
    // decimation 2, so the 4-frame history is full: trigger at t = 20. The
    // trigger tick 20 is odd in the decimation phase? It is kept regardless:
    // the decimation restarts at the trigger.
    auto sig = [](uint32_t t) {
        Vec v{};
        v[signal_index(SignalId::kR)] = (t / 20) % 2 ? 1.0f : 0.0f;
        v[signal_index(SignalId::kY)] = static_cast<float>(t);
        return v;
    };
    // Start at tick 1 so that the crossing tick 20 is not on the decimation grid (1, 3, 5, ...).
    for (uint32_t t = 1; t < 200; ++t) rec.push(t, sig(t));
    EXPECT_EQ(rec.state(), RecorderState::kDone);
    EXPECT_EQ(rec.trigger_tick(), 20u);
    const auto f = drain(rec);
    ASSERT_EQ(f.size(), 12u);
    // History: the last 4 kept ticks before 20 on the old grid: 13, 15, 17, 19.
    const uint32_t want[] = {13, 15, 17, 19, 20, 22, 24, 26, 28, 30, 32, 34};
    for (std::size_t i = 0; i < 12; ++i) {
        EXPECT_EQ(f[i].tick, want[i]) << i;
        EXPECT_EQ(f[i].value[0], static_cast<float>(want[i]));
    }
}

TEST(Recorder, TriggerIsHeldOffUntilTheHistoryIsFull) {
    piezoloop::Recorder<float, 1, 16> rec;
    piezoloop::RecorderConfig<1> c;
    c.channels = {0};
    c.trigger = TriggerMode::kFalling;
    c.trigger_signal = 1;
    c.trigger_level = 0.0f;
    c.pre_trigger = 5;
    c.length = 8;
    ASSERT_TRUE(rec.configure(c).ok());
    ASSERT_TRUE(rec.arm());
    // Signal 1 falls through 0 every 4 ticks (+1,+1,-1,-1): crossings at
    // t = 2, 6, 10, ... The first two come before 5 history frames exist.
    for (uint32_t t = 0; t < 40; ++t) {
        Vec v{};
        v[0] = static_cast<float>(t);
        v[1] = (t % 4) < 2 ? 1.0f : -1.0f;
        rec.push(t, v);
    }
    EXPECT_EQ(rec.trigger_tick(), 6u);  // at t = 2 only 2 frames of history
    const auto f = drain(rec);
    ASSERT_EQ(f.size(), 8u);
    for (std::size_t i = 0; i < 8; ++i) EXPECT_EQ(f[i].tick, 1 + i);  // 1..5 history, 6 trigger, 7, 8
}

TEST(Recorder, Q31LevelTriggerUsesTheSignalScale) {
    piezoloop::Recorder<Q31, 1, 16> rec;
    piezoloop::RecorderConfig<1> c;
    c.channels = {signal_index(SignalId::kU)};
    c.trigger = TriggerMode::kRising;
    c.trigger_signal = signal_index(SignalId::kU);
    c.trigger_level = 75.0f;                // V
    c.trigger_scale = SignalScale{150.0f};  // -> 0.5 full scale
    c.length = 4;
    ASSERT_TRUE(rec.configure(c).ok());
    ASSERT_TRUE(rec.arm());
    for (uint32_t t = 0; t < 100; ++t) {
        std::array<Q31, kSig> v{};
        v[signal_index(SignalId::kU)] = Q31::from_double(0.01 * t);  // crosses 0.5 at t = 50
        rec.push(t, v);
    }
    EXPECT_EQ(rec.trigger_tick(), 50u);
    std::array<decltype(rec)::Frame, 8> buf{};
    ASSERT_EQ(rec.read(buf), 4u);
    EXPECT_EQ(buf[0].value[0], Q31::from_double(0.5));
}

TEST(Recorder, ContinuousOrderingAcrossWrapAround) {
    // 8-frame ring, 200000 frames through it (the uint32 sequence numbers
    // start 65536 below their wrap, so they wrap too). The reader keeps up
    // (reads every 3 pushes, up to 5 frames): no overruns, every tick present.
    piezoloop::Recorder<float, 1, 8> rec;
    piezoloop::RecorderConfig<1> c;
    c.channels = {0};
    c.mode = RecordMode::kContinuous;
    ASSERT_TRUE(rec.configure(c).ok());
    ASSERT_TRUE(rec.arm());
    std::array<decltype(rec)::Frame, 5> buf{};
    uint32_t expect = 0;
    for (uint32_t t = 0; t < 200000; ++t) {
        Vec v{};
        v[0] = static_cast<float>(t & 0xffff);
        rec.push(t, v);
        if (t % 3 == 2) {
            const std::size_t n = rec.read(buf);
            for (std::size_t i = 0; i < n; ++i) {
                ASSERT_EQ(buf[i].tick, expect);
                ASSERT_EQ(buf[i].value[0], static_cast<float>(expect & 0xffff));
                ++expect;
            }
        }
    }
    while (const std::size_t n = rec.read(buf)) {
        for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(buf[i].tick, expect++);
    }
    EXPECT_EQ(expect, 200000u);
    EXPECT_EQ(rec.overruns(), 0u);
    EXPECT_EQ(rec.state(), RecorderState::kTriggered);
}

TEST(Recorder, OverrunsAreCountedNeverSilent) {
    // Reader drains 4 frames every 20 pushes from a 16-frame ring: it falls
    // behind, the writer drops the newest frames. Every produced frame is
    // either read or counted, and the gaps in the read ticks add up to the count.
    piezoloop::Recorder<float, 1, 16> rec;
    piezoloop::RecorderConfig<1> c;
    c.channels = {0};
    c.mode = RecordMode::kContinuous;
    c.decimation = 2;
    ASSERT_TRUE(rec.configure(c).ok());
    ASSERT_TRUE(rec.arm());
    std::vector<uint32_t> ticks;
    std::array<decltype(rec)::Frame, 4> buf{};
    const uint32_t n_ticks = 20000;
    for (uint32_t t = 0; t < n_ticks; ++t) {
        rec.push(t, signals_at(t));
        if (t % 20 == 19) {
            const std::size_t n = rec.read(buf);
            for (std::size_t i = 0; i < n; ++i) ticks.push_back(buf[i].tick);
        }
    }
    for (std::size_t n; (n = rec.read(buf)) != 0;) {
        for (std::size_t i = 0; i < n; ++i) ticks.push_back(buf[i].tick);
    }
    const uint32_t produced = n_ticks / 2;
    EXPECT_GT(rec.overruns(), 0u);
    EXPECT_EQ(ticks.size() + rec.overruns(), produced);
    uint64_t gaps = 0;
    for (std::size_t i = 1; i < ticks.size(); ++i) {
        ASSERT_GT(ticks[i], ticks[i - 1]);          // in order
        ASSERT_EQ((ticks[i] - ticks[i - 1]) % 2, 0u);  // on the decimation grid
        gaps += (ticks[i] - ticks[i - 1]) / 2 - 1;
    }
    EXPECT_EQ(ticks.front(), 0u);
    // Dropped frames are the newest at the time, so the tail of the run can
    // also be missing: count what lies after the last read tick.
    gaps += (n_ticks - 2 - ticks.back()) / 2;
    EXPECT_EQ(gaps, rec.overruns());
}

TEST(Recorder, StopAndRearm) {
    piezoloop::Recorder<float, 1, 8> rec;
    piezoloop::RecorderConfig<1> c;
    c.channels = {0};
    c.mode = RecordMode::kContinuous;
    EXPECT_FALSE(rec.arm());  // not configured
    ASSERT_TRUE(rec.configure(c).ok());
    ASSERT_TRUE(rec.arm());
    for (uint32_t t = 0; t < 5; ++t) rec.push(t, signals_at(t));
    rec.stop();
    EXPECT_EQ(rec.state(), RecorderState::kIdle);
    for (uint32_t t = 5; t < 9; ++t) rec.push(t, signals_at(t));  // ignored
    EXPECT_EQ(rec.available(), 5u);                               // still readable
    ASSERT_TRUE(rec.arm());                                       // discards them
    EXPECT_EQ(rec.available(), 0u);
    rec.push(42, signals_at(42));
    std::array<decltype(rec)::Frame, 8> buf{};
    ASSERT_EQ(rec.read(buf), 1u);
    EXPECT_EQ(buf[0].tick, 42u);
}

TEST(Recorder, ValidationKeepsTheOldConfiguration) {
    piezoloop::Recorder<float, 2, 16> rec;
    piezoloop::RecorderConfig<2> good;
    good.channels = {0, 3};
    good.decimation = 5;
    ASSERT_TRUE(rec.configure(good).ok());
    struct Case { piezoloop::RecorderConfig<2> c; const char* field; };
    std::vector<Case> cases;
    auto with = [&](auto edit, const char* field) { auto c = good; edit(c); cases.push_back({c, field}); };
    with([](auto& c) { c.channels[1] = 8; }, "channels");
    with([](auto& c) { c.decimation = 0; }, "decimation");
    with([](auto& c) { c.trigger_signal = 9; }, "trigger_signal");
    with([](auto& c) { c.pre_trigger = 1; }, "pre_trigger");  // with an immediate trigger
    with([](auto& c) { c.length = 17; }, "length");
    with([](auto& c) { c.trigger = TriggerMode::kRising; c.length = 4; c.pre_trigger = 4; }, "pre_trigger");
    with([](auto& c) { c.trigger = TriggerMode::kRising; c.trigger_level = NAN; }, "trigger_level");
    with([](auto& c) { c.mode = RecordMode::kContinuous; c.trigger = TriggerMode::kRising; c.pre_trigger = 16; },
         "pre_trigger");
    for (const Case& k : cases) {
        const auto s = rec.configure(k.c);
        ASSERT_FALSE(s.ok()) << k.field;
        EXPECT_STREQ(s.field, k.field);
        EXPECT_EQ(rec.config().decimation, 5u);
        EXPECT_EQ(rec.config().channels[1], 3u);
    }
    piezoloop::Recorder<Q31, 1, 16> q;
    piezoloop::RecorderConfig<1> qc;
    qc.trigger_scale = SignalScale{0.0f};
    EXPECT_STREQ(q.configure(qc).field, "trigger_scale");
}

TEST(Recorder, ConcurrentProducerAndConsumer) {
    // A real SPSC run: one thread pushes 2e6 ticks as fast as it can, the
    // other drains. Frames arrive in order, values match their ticks, and
    // read + overruns == produced.
    static piezoloop::Recorder<float, 2, 1024> rec;
    piezoloop::RecorderConfig<2> c;
    c.channels = {0, 1};
    c.mode = RecordMode::kContinuous;
    ASSERT_TRUE(rec.configure(c).ok());
    ASSERT_TRUE(rec.arm());
    constexpr uint32_t kTicks = 2'000'000;
    std::atomic<bool> done{false};
    std::thread writer([&] {
        for (uint32_t t = 0; t < kTicks; ++t) {
            Vec v{};
            v[0] = static_cast<float>(t & 0xffffff);
            v[1] = -static_cast<float>(t & 0xffffff);
            rec.push(t, v);
        }
        done.store(true, std::memory_order_release);
    });
    uint64_t got = 0;
    int64_t last = -1;
    bool ok = true;
    std::array<decltype(rec)::Frame, 64> buf{};
    for (;;) {
        const bool finished = done.load(std::memory_order_acquire);
        const std::size_t n = rec.read(buf);
        for (std::size_t i = 0; i < n; ++i) {
            const auto& f = buf[i];
            ok = ok && static_cast<int64_t>(f.tick) > last && f.value[0] == static_cast<float>(f.tick & 0xffffff) &&
                 f.value[1] == -f.value[0];
            last = f.tick;
        }
        got += n;
        if (finished && n == 0) break;
    }
    writer.join();
    EXPECT_TRUE(ok);
    EXPECT_EQ(got + rec.overruns(), kTicks);
}
