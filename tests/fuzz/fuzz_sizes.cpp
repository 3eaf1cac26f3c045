// libFuzzer target: the size and count fields of the requests, drawn near the
// values where 32-bit arithmetic wraps, sent as intact frames to the device
// on a Pipeline<float> or Pipeline<Q31> with the reference setup, with ticks
// and log polling between them as the firmware main loop runs them.
//
// Random bytes almost never hit 2^31 or 2^32 - 1 in a 32-bit field, so each
// size is built from the input as a boundary (0, 1, 2, the capacities,
// 2^31 - 1, 2^31, 2^31 + 1, 2^32 - 2, 2^32 - 1, ...) plus a small offset,
// or as raw bytes. The fields: StartExcitation's period_samples, first_bin,
// last_bin, prbs_order, prbs_hold and periods; the repetitive group's
// period_samples, m1 and m2; the recorder group's decimation, pre_trigger
// and length; the trajectory group's cycles; StreamStart's prefill and a
// setpoint block's sequence and count.
//
// A request the board cannot bound would hang the target (libFuzzer's
// -timeout reports it); besides the sanitizers' findings the target traps
// on a broken invariant: every intact request gets exactly one intact reply,
// the output stays within the hard limits, and an excitation the device
// accepts has a multisine's lines below Nyquist within the table and a
// period that fits the 32-bit sample counter.
//
// Build: clang++ -std=c++20 -g -O1 -fsanitize=fuzzer,address,undefined
//        -I common tests/fuzz/fuzz_sizes.cpp (tests/CMakeLists.txt does it).
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>

#include "piezoloop/link/device.hpp"
#include "piezoloop/reference_stage.hpp"

using namespace piezoloop;
using namespace piezoloop::link;

namespace {

// The fuzz input, consumed a byte at a time (0 once it runs out).
struct Input {
    std::span<const uint8_t> rest;
    uint8_t byte() {
        if (rest.empty()) return 0;
        const uint8_t b = rest[0];
        rest = rest.subspan(1);
        return b;
    }
    uint32_t raw32() {
        uint32_t v = 0;
        for (int i = 0; i < 4; ++i) v |= uint32_t{byte()} << (8 * i);
        return v;
    }
    // A boundary plus an offset in [-8, 7] (wrapping), or raw bytes.
    uint32_t size() {
        static constexpr std::array<uint32_t, 15> kBase = {
            0u, 1u, 2u, 4u, 1023u, 1024u, 65536u, 0x00ffffffu, 0x7ffffffeu, 0x7fffffffu, 0x80000000u, 0x80000001u,
            0xc0000000u, 0xfffffffeu, 0xffffffffu};
        const uint8_t b = byte();
        const uint32_t i = b & 15u;
        if (i == 15u) return raw32();
        return kBase[i] + static_cast<uint32_t>(static_cast<int32_t>(b >> 4) - 8);
    }
    float value() {
        static constexpr std::array<float, 8> kValues = {0.0f, 0.1f, 1.0f, -1.0f, 10.0f, 4999.0f, 1.0e30f,
                                                         std::numeric_limits<float>::quiet_NaN()};
        return kValues[byte() & 7u];
    }
};

struct Checker {
    FrameDecoder rx;
    std::size_t replies = 0;  // replies to requests (not log blocks)
    uint8_t last_type = 0;    // of the last reply
    void operator()(std::span<const uint8_t> frame) {
        const uint32_t before = rx.counters().frames_ok;
        rx.feed(frame, [&](std::span<const uint8_t> payload) {
            const uint8_t t = parse_header(payload).type;
            if (t != static_cast<uint8_t>(MsgType::kLogBlock)) {
                ++replies;
                last_type = t;
            }
        });
        if (rx.counters().frames_ok != before + 1 || rx.counters().dropped() != 0) __builtin_trap();
    }
};

// What an accepted excitation must satisfy, whatever the input.
void check_accepted(const ExcitationConfig& c, std::size_t capacity) {
    switch (c.signal) {
        case ExcitationSignal::kMultisine:
            if (c.period_samples > capacity || c.first_bin < 1 || c.last_bin < c.first_bin ||
                2u * uint64_t{c.last_bin} >= c.period_samples)
                __builtin_trap();
            break;
        case ExcitationSignal::kPrbs:
            if (c.prbs_order > 24 || ((uint64_t{1} << c.prbs_order) - 1u) * c.prbs_hold > 0xffffffffull) __builtin_trap();
            break;
        default:
            break;
    }
}

template <class T>
int run(Input in) {
    using Dev = Device<T>;
    const PipelineSetup setup = reference::setup();
    auto pipeline = std::make_unique<typename Dev::PipelineType>(setup);
    if (!pipeline->stage(reference::params(true, true, false)).ok()) __builtin_trap();
    pipeline->tick(setup.position.to_sample<T>(0.0f));
    auto device = std::make_unique<Dev>(*pipeline, DeviceInfo{"fuzz", "0", "0"});
    Checker check;
    std::array<uint8_t, kMaxFrameSize> frame{};
    uint16_t seq = 0;
    std::size_t sent = 0;
    T y = setup.position.to_sample<T>(0.0f);

    auto send = [&](const auto& m) {
        const std::size_t n = encode_message(m, ++seq, frame);
        if (n == 0) return false;
        const std::size_t before = check.replies;
        device->receive(std::span<const uint8_t>(frame.data(), n), check);
        ++sent;
        if (check.replies != before + 1) __builtin_trap();  // answered at once, exactly once
        return check.last_type == static_cast<uint8_t>(MsgType::kAck);
    };
    auto ticks = [&](int n) {
        for (int k = 0; k < n; ++k) {
            device->on_tick();
            const T u = pipeline->tick(y);
            const float u_V = setup.voltage.to_physical(u);
            if (!(u_V >= setup.hard.u_min_V && u_V <= setup.hard.u_max_V)) __builtin_trap();
            y = setup.position.to_sample<T>(0.5f * u_V);
        }
        while (device->poll_log(check)) {}
    };

    for (int step = 0; step < 16 && !in.rest.empty(); ++step) {
        switch (in.byte() % 8u) {
            case 0: {
                StartExcitation m;
                m.flags = static_cast<uint8_t>(in.byte() & (StartExcitation::kArmLoop | StartExcitation::kDetached));
                ExcitationConfig& c = m.config;
                c.signal = static_cast<ExcitationSignal>(in.byte() % 7u);
                c.point = static_cast<ExcitationPoint>(in.byte() & 1u);
                c.amplitude = in.value();
                c.offset = in.value();
                c.period_samples = in.size();
                c.first_bin = in.size();
                c.last_bin = in.size();
                c.f1_Hz = in.value();
                c.f2_Hz = in.value();
                c.prbs_order = in.byte();
                c.prbs_hold = in.size();
                c.periods = in.size();
                if (send(m)) check_accepted(c, Dev::PipelineType::Excitation::kTableCapacity);
                break;
            }
            case 1: send(StopExcitation{}); break;
            case 2: {
                RepetitiveParams v;
                v.enabled = (in.byte() & 1u) != 0;
                v.rc.period_samples = static_cast<int>(in.size());
                v.rc.m1 = static_cast<int>(in.size());
                v.rc.m2 = static_cast<int>(in.size());
                send(SetParams<RepetitiveParams>{v});
                break;
            }
            case 3: {
                RecorderParams v;
                v.channel_count = static_cast<uint8_t>(Dev::RecorderType::kChannels);
                v.decimation = in.size();
                v.mode = static_cast<RecordMode>(in.byte() % 3u);
                v.trigger = static_cast<TriggerMode>(in.byte() % 4u);
                v.pre_trigger = in.size();
                v.length = in.size();
                if (send(SetParams<RecorderParams>{v})) send(RecorderArm{});
                break;
            }
            case 4: {
                TrajectoryParams v;
                v.waveform = Waveform::kTriangle;
                v.amplitude_um = 1.0f;
                v.frequency_Hz = in.value();
                v.cycles = in.size();
                if (send(SetParams<TrajectoryParams>{v})) send(StartWave{static_cast<uint8_t>(in.byte() & 1u)});
                break;
            }
            case 5: {
                StreamStart s;
                s.prefill = static_cast<uint16_t>(in.size());
                send(s);
                SetpointBlock b;
                b.block_seq = in.size();
                b.count = static_cast<uint8_t>(in.byte() % (kMaxSetpointsPerBlock + 1));
                send(b);
                break;
            }
            case 6: send(Disarm{}); break;
            default: ticks(1 + in.byte() % 64); break;
        }
        ticks(2);
    }
    if (check.replies != sent || device->counters().frames_ok != sent) __builtin_trap();
    return 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const Input in{std::span<const uint8_t>(data + 1, size - 1)};
    return (data[0] & 1u) != 0 ? run<Q31>(in) : run<float>(in);
}
