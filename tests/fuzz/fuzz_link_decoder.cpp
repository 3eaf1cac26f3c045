// libFuzzer target: arbitrary bytes into the device's streaming frame decoder
// and dispatcher on a Pipeline<float> with the reference setup, and then on
// a three-axis MultiAxisPipeline<float, 3> of that setup, interleaved
// with ticks and log polling the way the firmware main loop runs them, with
// an in-memory parameter storage (Save / Load / Forget reach it).
//
// The first input byte picks how the rest is cut into chunks (the transports
// deliver arbitrary pieces). Besides the sanitizers' findings, the target
// traps on a broken invariant: every reply the device sends must itself be an
// intact frame, the output (every channel's) never leaves the hard limits,
// and every intact request frame gets exactly one reply.
//
// Build: clang++ -std=c++20 -g -O1 -fsanitize=fuzzer,address,undefined
//        -I common tests/fuzz/fuzz_link_decoder.cpp (tests/CMakeLists.txt does it).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>

#include "piezoloop/link/device.hpp"
#include "piezoloop/reference_stage.hpp"
#include "piezoloop/storage/memory_storage.hpp"

using namespace piezoloop;
using namespace piezoloop::link;

namespace {

struct Checker {
    FrameDecoder rx;
    std::size_t replies = 0;   // replies to requests (not log blocks)
    void operator()(std::span<const uint8_t> frame) {
        const uint32_t before = rx.counters().frames_ok;
        rx.feed(frame, [&](std::span<const uint8_t> payload) {
            if (parse_header(payload).type != static_cast<uint8_t>(MsgType::kLogBlock)) ++replies;
        });
        if (rx.counters().frames_ok != before + 1 || rx.counters().dropped() != 0) __builtin_trap();
    }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    const PipelineSetup setup = reference::setup();
    auto pipeline = std::make_unique<Pipeline<float>>(setup);
    // A configured, running loop so that arm / wave / stream requests do something.
    if (!pipeline->stage(reference::params(true, true, false)).ok()) __builtin_trap();
    pipeline->tick(0.0f);
    auto storage = std::make_unique<storage::MemoryStorage>();
    DeviceHooks hooks;
    hooks.storage = storage.get();
    auto device = std::make_unique<Device<float>>(*pipeline, DeviceInfo{"fuzz", "0", "0"}, hooks);
    Checker check;

    if (size == 0) return 0;
    const std::size_t chunk = 1 + data[0] % 97;
    std::span<const uint8_t> rest(data + 1, size - 1);
    float y = 0.0f;
    while (!rest.empty()) {
        const std::size_t n = rest.size() < chunk ? rest.size() : chunk;
        device->receive(rest.first(n), check);
        rest = rest.subspan(n);
        for (int k = 0; k < 3; ++k) {
            device->on_tick();
            const float u = pipeline->tick(y);
            if (!(u >= setup.hard.u_min_V && u <= setup.hard.u_max_V)) __builtin_trap();
            y = 0.5f * u;  // a crude plant, so the loop has something to chew on
        }
        while (device->poll_log(check)) {}
    }
    // Every delivered request frame was answered exactly once.
    if (check.replies != device->counters().frames_ok) __builtin_trap();

    // The same bytes to a three-axis board.
    using Multi = MultiAxisPipeline<float, 3, 1024, 8, 1024, 1024>;
    MultiAxisSetup<3> ms{};
    for (int i = 0; i < 3; ++i) {
        ms.axes[i] = setup;
        ms.channels[i] = setup.hard;
    }
    auto multi = std::make_unique<Multi>(ms);
    for (int i = 0; i < 3; ++i)
        if (!multi->axis(i).stage(reference::params(true, true, false)).ok()) __builtin_trap();
    multi->tick({});
    auto storage3 = std::make_unique<storage::MemoryStorage>();
    DeviceHooks hooks3;
    hooks3.storage = storage3.get();
    auto device3 = std::make_unique<Device<float, 1024, 8, 1024, 1024, 1024, 3, true>>(
        *multi, DeviceInfo{"fuzz-xyz", "0", "0"}, hooks3);
    Checker check3;
    rest = std::span<const uint8_t>(data + 1, size - 1);
    Multi::Samples ys{};
    while (!rest.empty()) {
        const std::size_t n = rest.size() < chunk ? rest.size() : chunk;
        device3->receive(rest.first(n), check3);
        rest = rest.subspan(n);
        for (int k = 0; k < 3; ++k) {
            device3->on_tick();
            const Multi::Samples u = multi->tick(ys);
            for (int i = 0; i < 3; ++i) {
                if (!(u[i] >= setup.hard.u_min_V && u[i] <= setup.hard.u_max_V)) __builtin_trap();
                ys[i] = 0.5f * u[i];
            }
        }
        while (device3->poll_log(check3)) {}
    }
    if (check3.replies != device3->counters().frames_ok) __builtin_trap();
    return 0;
}
