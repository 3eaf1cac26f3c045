// Test-side client for the link tests: encodes requests, runs them through a
// Device, and decodes the reply frames with the same FrameDecoder a host uses.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "piezoloop/link/device.hpp"
#include "piezoloop/reference_stage.hpp"

namespace link_test {

using namespace piezoloop;
using namespace piezoloop::link;

struct Reply {
    FrameHeader header;
    std::vector<uint8_t> body;
    MsgType type() const { return static_cast<MsgType>(header.type); }
    template <class M>
    M as() const {
        M m{};
        EXPECT_EQ(header.type, static_cast<uint8_t>(M::kType));
        EXPECT_EQ(decode_body(std::span<const uint8_t>(body), m), DecodeResult::kOk);
        return m;
    }
};

template <class T>
struct Rig {
    using DeviceT = Device<T>;
    std::unique_ptr<typename DeviceT::PipelineType> pipeline;
    std::unique_ptr<DeviceT> device;
    FrameDecoder host_rx;
    std::vector<Reply> replies;
    uint16_t seq = 0;

    explicit Rig(const DeviceHooks& hooks = {}, const char* firmware_version = "1.2.3")
        : pipeline(std::make_unique<typename DeviceT::PipelineType>(reference::setup())),
          device(std::make_unique<DeviceT>(*pipeline, DeviceInfo{"test-board", firmware_version, "SN0001"}, hooks)) {}

    auto sink() {
        return [this](std::span<const uint8_t> frame) {
            host_rx.feed(frame, [this](std::span<const uint8_t> payload) {
                Reply r;
                r.header = parse_header(payload);
                r.body.assign(payload.begin() + kHeaderSize, payload.end());
                replies.push_back(std::move(r));
            });
        };
    }

    // Raw bytes to the device; returns the replies they produced.
    std::vector<Reply> send_bytes(std::span<const uint8_t> bytes) {
        replies.clear();
        device->receive(bytes, sink());
        return replies;
    }

    template <class M>
    std::vector<uint8_t> frame(const M& m, uint16_t s) {
        std::vector<uint8_t> f(kMaxFrameSize);
        const std::size_t n = encode_message(m, s, f);
        EXPECT_GT(n, 0u);
        f.resize(n);
        return f;
    }

    // One request; expects exactly one reply with its sequence id.
    template <class M>
    Reply request(const M& m) {
        const uint16_t s = ++seq;
        const auto f = frame(m, s);
        auto r = send_bytes(f);
        EXPECT_EQ(r.size(), 1u);
        if (r.empty()) return Reply{};
        EXPECT_EQ(r[0].header.seq, s);
        return r[0];
    }

    void tick(int n = 1) {
        for (int i = 0; i < n; ++i) {
            device->on_tick();
            pipeline->tick(sample_zero<T>());
        }
    }

    template <class G>
    G get(ParamGroup g) {
        return request(GetParams{g}).template as<ParamsReply<G>>().value;
    }
    template <class G>
    Reply set(const G& v) {
        return request(SetParams<G>{v});
    }
};

}  // namespace link_test
