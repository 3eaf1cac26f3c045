// The host link client (host/link/client.hpp) and the TCP transport against
// the real device dispatcher (link::Device<float>, the firmware's code)
// served from a thread over loopback TCP, the thread ticking the pipeline.
// The device side is the reference: request/reply, error texts, streaming
// flow control, log reassembly and loss detection (blocks dropped or
// swapped on purpose by the server), closed-link and reconnect behaviour.
// Comparisons are exact: the link moves bit patterns.
#include <gtest/gtest.h>
#include <string>

#include <limits>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <mutex>
#include <thread>
#include <vector>

#include "link/client.hpp"
#include "link/tcp_transport.hpp"
#include "piezoloop/link/device.hpp"
#include "piezoloop/reference_stage.hpp"

using namespace piezoloop;
using namespace piezoloop::hostlink;
using namespace std::chrono_literals;

namespace {

// The device's y input at tick k: a function of the tick alone, so every
// logged frame can be checked against its tick index.
float y_of_tick(uint32_t k) { return static_cast<float>(k & 0xffffu) * 1e-3f; }

class DeviceServer {
public:
    using DeviceT = link::Device<float>;

    DeviceServer() : pipeline_(std::make_unique<DeviceT::PipelineType>(reference::setup())),
                     device_(std::make_unique<DeviceT>(*pipeline_, link::DeviceInfo{"test-board", "9.9.9", "SN42"})) {
        listen_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        a.sin_port = 0;
        EXPECT_EQ(::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
        EXPECT_EQ(::listen(listen_fd_, 4), 0);
        socklen_t len = sizeof a;
        ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
        port_ = ntohs(a.sin_port);
        thread_ = std::thread([this] { run(); });
    }
    ~DeviceServer() {
        stop_ = true;
        thread_.join();
        ::close(listen_fd_);
    }

    std::string address() const { return "tcp:127.0.0.1:" + std::to_string(port_); }
    std::atomic<int> ticks_per_iteration{20};
    std::atomic<int> drop_log_block{-1};   // index (from recorder arm) of a block not sent
    std::atomic<int> swap_log_block{-1};   // this block is sent after the next one
    std::atomic<bool> close_connection{false};

private:
    void run() {
        while (!stop_) {
            pollfd p{listen_fd_, POLLIN, 0};
            if (::poll(&p, 1, 10) <= 0) continue;
            const int fd = ::accept(listen_fd_, nullptr, nullptr);
            if (fd < 0) continue;
            device_->decoder().reset();
            serve(fd);
            ::close(fd);
        }
    }

    void serve(int fd) {
        bool alive = true;
        auto send = [&](std::span<const uint8_t> f) {
            if (!alive) return;
            std::size_t done = 0;
            while (done < f.size()) {
                const ssize_t n = ::send(fd, f.data() + done, f.size() - done, MSG_NOSIGNAL);
                if (n <= 0) { alive = false; return; }
                done += static_cast<std::size_t>(n);
            }
        };
        int block_index = 0;
        std::vector<uint8_t> held;
        auto log_send = [&](std::span<const uint8_t> f) {
            const int i = block_index++;
            if (i == drop_log_block) return;
            if (i == swap_log_block) { held.assign(f.begin(), f.end()); return; }
            send(f);
            if (!held.empty()) { send(held); held.clear(); }
        };
        std::array<uint8_t, 2048> buf;
        while (!stop_ && alive) {
            if (close_connection.exchange(false)) return;
            pollfd p{fd, POLLIN, 0};
            if (::poll(&p, 1, 0) > 0) {
                const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
                if (n <= 0) return;
                device_->receive(std::span<const uint8_t>(buf.data(), static_cast<std::size_t>(n)), send);
            }
            if (device_->pipeline().recorder().state() == RecorderState::kIdle) block_index = 0;
            for (int i = ticks_per_iteration; i > 0; --i) {
                device_->on_tick();
                pipeline_->tick(y_of_tick(pipeline_->tick_count()));
            }
            while (device_->poll_log(log_send)) {}
            std::this_thread::sleep_for(50us);
        }
    }

    std::unique_ptr<DeviceT::PipelineType> pipeline_;
    std::unique_ptr<DeviceT> device_;
    int listen_fd_ = -1;
    uint16_t port_ = 0;
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

Client connect(const DeviceServer& s, std::chrono::milliseconds timeout = 2000ms) {
    Client::Options o;
    o.timeout = timeout;
    return Client(open_transport(s.address()), o);
}

void configure_reference(Client& c) {
    const PipelineParams p = reference::params(true, true, false);
    c.set(link::LimitsParams{p.limits});
    c.set(link::FeedforwardParams{p.feedforward, p.pi, p.dahl});
    c.set(link::FeedbackParams{p.feedback, p.sos_count, p.sos, p.pid});
}

link::RecorderParams recorder_ryeu(uint32_t decimation = 1) {
    link::RecorderParams r;
    r.channel_count = 4;
    r.channels = {0, 1, 2, 3};
    r.decimation = decimation;
    r.mode = RecordMode::kContinuous;
    return r;
}

// Records until `frames` frames arrived (or 10 s), calling status() between
// reads so that log blocks also arrive while a reply is awaited.
void record(Client& c, std::size_t frames) {
    c.recorder_arm();
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (c.log().size() < frames && std::chrono::steady_clock::now() < deadline) {
        c.pump(5ms);
        (void)c.status();
    }
    c.recorder_stop();
    c.pump(50ms);
    c.log().finish();
}

// Every frame's y is y_of_tick(its tick): the reassembly put each sample at
// the tick it was recorded.
void expect_frames_match_ticks(const LogCollector& log) {
    ASSERT_EQ(log.channel_count(), 4u);
    for (std::size_t i = 0; i < log.size(); ++i) {
        const uint32_t tick = log.first_tick_raw() + static_cast<uint32_t>(log.tick(i));
        ASSERT_EQ(std::bit_cast<float>(log.raw(i)[1]), y_of_tick(tick)) << "frame " << i;
    }
}

TEST(HostLinkClient, HelloOverTcpNamesTheBoard) {
    DeviceServer s;
    Client c = connect(s);
    const link::HelloReply& h = c.hello();
    EXPECT_EQ(h.protocol_version, link::kProtocolVersion);
    EXPECT_STREQ(h.board.data(), "test-board");
    EXPECT_STREQ(h.serial.data(), "SN42");
    EXPECT_EQ(h.loop_rate_Hz, reference::setup().rate_Hz);
    EXPECT_EQ(h.hard_u_max_V, reference::setup().hard.u_max_V);
    EXPECT_EQ(h.recorder_channels, 4);
    EXPECT_EQ(c.address(), s.address());
}

TEST(HostLinkClient, ParameterGroupsRoundTripBitForBit) {
    DeviceServer s;
    Client c = connect(s);
    configure_reference(c);
    const PipelineParams p = reference::params(true, true, false);
    EXPECT_TRUE(c.get<link::LimitsParams>() == link::LimitsParams{p.limits});
    EXPECT_EQ(c.get<link::FeedforwardParams>(), (link::FeedforwardParams{p.feedforward, p.pi, p.dahl}));
    EXPECT_EQ(c.get<link::FeedbackParams>(), (link::FeedbackParams{p.feedback, p.sos_count, p.sos, p.pid}));
    c.arm();
    EXPECT_TRUE(c.status().armed);
    c.disarm();
    EXPECT_FALSE(c.status().armed);
    // Back-to-back sets hit "busy" until the tick swaps: retried, not failed.
    EXPECT_GT(c.counters().requests, 5u);
}

TEST(HostLinkClient, ErrorReplyBecomesDeviceErrorNamingTheField) {
    DeviceServer s;
    Client c = connect(s);
    // Arm before any limits: the limiter is tripped as "not configured".
    try {
        c.arm();
        FAIL() << "arm accepted without limits";
    } catch (const DeviceError& e) {
        EXPECT_EQ(e.code(), link::ErrorCode::kTripped);
        EXPECT_NE(std::string(e.what()).find("Arm refused (tripped)"), std::string::npos) << e.what();
    }
    // Limits beyond the hard limits: invalid_param naming limits.<field>.
    LimitsConfig l = reference::params().limits;
    l.u_max_V = reference::setup().hard.u_max_V + 10.0f;
    try {
        c.set(link::LimitsParams{l});
        FAIL() << "limits beyond the hard limits accepted";
    } catch (const DeviceError& e) {
        EXPECT_EQ(e.code(), link::ErrorCode::kInvalidParam);
        EXPECT_EQ(e.group(), "limits");
        EXPECT_FALSE(e.field().empty());
        const std::string w = e.what();
        EXPECT_NE(w.find("SetParams refused (invalid_param): limits." + e.field() + ": "), std::string::npos) << w;
        EXPECT_GT(std::strlen(e.reply().message.data()), 0u);
    }
    // An array element: PI thresholds not ascending names the index.
    configure_reference(c);
    link::FeedforwardParams ff = c.get<link::FeedforwardParams>();
    ASSERT_GE(ff.pi.count, 3);
    ff.pi.thresholds[2] = ff.pi.thresholds[1];
    try {
        c.set(ff);
        FAIL() << "non-ascending thresholds accepted";
    } catch (const DeviceError& e) {
        EXPECT_EQ(e.code(), link::ErrorCode::kInvalidParam);
        EXPECT_EQ(e.group(), "feedforward");
        EXPECT_EQ(e.field(), "pi.thresholds");
        EXPECT_NE(std::string(e.what()).find("feedforward.pi.thresholds[2]"), std::string::npos) << e.what();
    }
    // The rejected set changed nothing.
    EXPECT_EQ(c.get<link::FeedforwardParams>().pi.thresholds, reference::params().pi.thresholds);
}

TEST(HostLinkClient, StreamKeepsTheFifoFilledWithoutOverflow) {
    DeviceServer s;
    s.ticks_per_iteration = 2;  // slower than the host: the FIFO fills and the client must wait on `free`
    Client c = connect(s, 5000ms);
    configure_reference(c);
    std::vector<float> sp(4000);
    for (std::size_t i = 0; i < sp.size(); ++i) sp[i] = 0.001f * static_cast<float>(i % 997);
    const StreamResult r = c.stream(sp, 512);
    EXPECT_EQ(r.sent, sp.size());
    EXPECT_EQ(r.blocks, (sp.size() + 119) / 120);
    EXPECT_TRUE(r.drained);
    EXPECT_EQ(r.consumed, sp.size());
    EXPECT_EQ(r.capacity, 1024);
    // The device is slower than the host, so its FIFO never ran empty.
    EXPECT_EQ(r.underruns, 0u);
    const link::StatusReply st = c.status();
    EXPECT_FALSE(st.streaming);
    EXPECT_EQ(st.r_um, sp.back());  // the setpoint holds its last value
}

TEST(HostLinkClient, PrefillOfTheWholeFifoIsReached) {
    // Blocks of 120 never add up to the 1024-slot FIFO: the client must send
    // a partial block, or the device would never start consuming.
    DeviceServer s;
    s.ticks_per_iteration = 50;
    Client c = connect(s);
    configure_reference(c);
    const std::vector<float> sp(3000, 2.5f);
    const StreamResult r = c.stream(sp, 1024);
    EXPECT_EQ(r.sent, sp.size());
    EXPECT_TRUE(r.drained);
    EXPECT_EQ(r.consumed, sp.size());
}

TEST(HostLinkClient, StreamUnderrunsAreReported) {
    DeviceServer s;
    s.ticks_per_iteration = 200;
    Client c = connect(s);
    configure_reference(c);
    // Prefill 0 starts consuming at once; the host waits before the first
    // block, so the device counts underruns, and the stream reports them.
    c.stream_start(0);
    std::this_thread::sleep_for(20ms);
    const std::vector<float> sp(100, 1.0f);
    const link::SetpointAck a = c.send_setpoints(sp);
    EXPECT_GT(a.underruns, 0u);
    c.stream_stop(false);
}

TEST(HostLinkClient, AStreamWithABadSetpointNeverStarts) {
    // Values finite in double but not in float, or beyond the board's range:
    // refused before StreamStart, naming the setpoint; nothing streams.
    DeviceServer s;
    Client c = connect(s);
    configure_reference(c);
    for (const float bad : {std::numeric_limits<float>::infinity(), 2.0e6f, std::numeric_limits<float>::quiet_NaN()}) {
        std::vector<float> sp(500, 1.0f);
        sp[321] = bad;
        try {
            c.stream(sp, 100);
            FAIL() << "stream accepted " << bad;
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("setpoint 321:"), std::string::npos) << e.what();
        }
        EXPECT_FALSE(c.status().streaming);
    }
}

TEST(HostLinkClient, LogBlocksReassembleWithoutLoss) {
    DeviceServer s;
    Client c = connect(s);
    c.hello();
    c.set(recorder_ryeu());
    record(c, 3000);
    const LogStats& st = c.log().stats();
    EXPECT_GE(st.frames, 3000u);
    EXPECT_TRUE(st.clean()) << "lost " << st.lost_blocks << " ooo " << st.out_of_order << " gaps " << st.tick_gaps;
    EXPECT_EQ(c.log().stride(), 1u);
    for (std::size_t i = 1; i < c.log().size(); ++i) ASSERT_EQ(c.log().tick(i), c.log().tick(i - 1) + 1);
    expect_frames_match_ticks(c.log());
    EXPECT_EQ(c.counters().stale_replies, 0u);
}

TEST(HostLinkClient, DecimatedLogHasTheStride) {
    DeviceServer s;
    Client c = connect(s);
    c.set(recorder_ryeu(7));
    record(c, 500);
    EXPECT_TRUE(c.log().stats().clean());
    EXPECT_EQ(c.log().stride(), 7u);
    for (std::size_t i = 1; i < c.log().size(); ++i) ASSERT_EQ(c.log().tick(i), c.log().tick(i - 1) + 7);
    expect_frames_match_ticks(c.log());
}

TEST(HostLinkClient, DroppedLogBlockIsCountedAsLostAndAsATickGap) {
    DeviceServer s;
    s.drop_log_block = 3;
    Client c = connect(s);
    c.set(recorder_ryeu());
    record(c, 3000);
    const LogStats& st = c.log().stats();
    EXPECT_EQ(st.lost_blocks, 1u);
    EXPECT_EQ(st.tick_gaps, 1u);
    EXPECT_EQ(st.missing_frames, link::log_frames_per_block(4));  // one full block of frames
    EXPECT_EQ(st.out_of_order, 0u);
    EXPECT_FALSE(st.clean());
    // The frames around the hole are still at their own ticks.
    expect_frames_match_ticks(c.log());
}

TEST(HostLinkClient, OutOfOrderBlockIsReorderedAndCounted) {
    DeviceServer s;
    s.swap_log_block = 2;
    Client c = connect(s);
    c.set(recorder_ryeu());
    record(c, 3000);
    const LogStats& st = c.log().stats();
    EXPECT_EQ(st.out_of_order, 1u);
    EXPECT_EQ(st.lost_blocks, 0u);
    EXPECT_EQ(st.tick_gaps, 0u);  // re-ordered within the window
    for (std::size_t i = 1; i < c.log().size(); ++i) ASSERT_EQ(c.log().tick(i), c.log().tick(i - 1) + 1);
    expect_frames_match_ticks(c.log());
}

TEST(HostLinkClient, ClosedLinkThrowsAndAReconnectFindsTheSameDevice) {
    DeviceServer s;
    {
        Client c = connect(s);
        configure_reference(c);
        s.close_connection = true;
        std::this_thread::sleep_for(50ms);
        try {
            (void)c.status();
            FAIL() << "status over a closed link";
        } catch (const DeviceError&) {
            FAIL() << "not a device error";
        } catch (const LinkError& e) {
            EXPECT_NE(std::string(e.what()).find("closed"), std::string::npos) << e.what();
            EXPECT_EQ(std::string(e.what()).rfind(s.address(), 0), 0u) << e.what();
        }
    }
    Client again = connect(s);
    EXPECT_STREQ(again.hello().board.data(), "test-board");
    // The parameters set in the first session are still there.
    EXPECT_TRUE(again.get<link::LimitsParams>() == link::LimitsParams{reference::params().limits});
}

// A device that never sends a byte is what a client sees when the board
// serves another connection: the message says so. One that sent something
// (here a frame of idle fill) but not the reply gets the plain timeout.
TEST(HostLinkClient, SilentDeviceTimesOutNamingTheRequest) {
    int sv[2];
    ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
    Client::Options o;
    o.timeout = 100ms;
    Client c(adopt_socket(sv[0], "test:silent"), o);
    try {
        (void)c.status();
        FAIL() << "no timeout";
    } catch (const LinkError& e) {
        const std::string text = e.what();
        EXPECT_EQ(text.rfind("test:silent: no reply to GetStatus within 100 ms, and nothing at all was received: "
                             "the board is busy with another client", 0), 0u) << text;
    }
    const uint8_t idle = 0;
    ASSERT_EQ(::write(sv[1], &idle, 1), 1);
    try {
        (void)c.status();
        FAIL() << "no timeout";
    } catch (const LinkError& e) {
        EXPECT_STREQ(e.what(), "test:silent: no reply to GetStatus within 100 ms");
    }
    ::close(sv[1]);
}

TEST(HostLinkClient, OtherProtocolVersionIsRefusedAtHello) {
    int sv[2];
    ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
    // A fake device that answers every frame with a HelloReply of another
    // (future) version.
    constexpr uint8_t kOther = link::kProtocolVersion + 1;
    std::thread fake([fd = sv[1], kOther] {
        link::FrameDecoder d;
        std::array<uint8_t, 1024> buf;
        const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
        if (n <= 0) return;
        d.feed(std::span<const uint8_t>(buf.data(), static_cast<std::size_t>(n)), [&](std::span<const uint8_t> p) {
            link::HelloReply h;
            h.protocol_version = kOther;
            std::array<uint8_t, link::kMaxFrameSize> out;
            const std::size_t m = link::encode_message(h, link::parse_header(p).seq, out, kOther);
            (void)::send(fd, out.data(), m, MSG_NOSIGNAL);
        });
    });
    Client c(adopt_socket(sv[0], "test:v2"));
    try {
        c.hello();
        FAIL() << "another version accepted";
    } catch (const LinkError& e) {
        EXPECT_NE(std::string(e.what()).find("protocol version " + std::to_string(kOther)), std::string::npos) << e.what();
    }
    fake.join();
    ::close(sv[1]);
}

TEST(HostLinkTransport, AddressFormsAndErrors) {
    auto message = [](const std::string& a) {
        try {
            (void)open_transport(a);
        } catch (const LinkError& e) {
            return std::string(e.what());
        }
        return std::string("opened");
    };
    // A malformed address is bad input (std::invalid_argument: exit 2), not a
    // link failure.
    for (const char* a : {"", "bogus", "tcp:", "tcp:host", "tcp:host:0", "tcp:host:65536", "tcp:host:12x", "usb:",
                          "serial:", "serial:/dev/null@fast"}) {
        try {
            (void)open_transport(a);
            ADD_FAILURE() << a << ": opened";
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("accepted forms: tcp:HOST:PORT"), std::string::npos) << a << ": " << e.what();
        } catch (const std::exception& e) {
            ADD_FAILURE() << a << ": not bad input: " << e.what();
        }
    }
    // A port nobody listens on: refused, naming the address.
    int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    socklen_t len = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    const std::string addr = "tcp:127.0.0.1:" + std::to_string(ntohs(a.sin_port));
    ::close(fd);  // bound, never listened: connections are refused
    EXPECT_EQ(message(addr), addr + ": connection refused (is the board or `piezoloop emulate` running?)");
    EXPECT_NE(message("serial:/nonexistent/tty").find("serial:/nonexistent/tty@115200: cannot open"), std::string::npos);
    EXPECT_NE(message("serial:/dev/null@57600").find("not a serial device"), std::string::npos);
    EXPECT_NE(message("serial:/dev/null@12345").find("unsupported baud rate"), std::string::npos);
}

TEST(HostLinkSerial, DeviceOverAPseudoTerminal) {
    // The serial transport on a pty: the test holds the master side and
    // serves the device there; the client opens the slave as a tty (raw 8N1).
    const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
    ASSERT_GE(master, 0);
    ASSERT_EQ(::grantpt(master), 0);
    ASSERT_EQ(::unlockpt(master), 0);
    const std::string path = ::ptsname(master);
    auto pipeline = std::make_unique<link::Device<float>::PipelineType>(reference::setup());
    link::Device<float> device(*pipeline, link::DeviceInfo{"pty-board", "1", "SN7"});
    std::atomic<bool> stop{false};
    std::thread server([&] {
        std::array<uint8_t, 1024> buf;
        auto send = [&](std::span<const uint8_t> f) {
            std::size_t done = 0;
            while (done < f.size()) {
                const ssize_t n = ::write(master, f.data() + done, f.size() - done);
                if (n <= 0) return;
                done += static_cast<std::size_t>(n);
            }
        };
        while (!stop) {
            pollfd p{master, POLLIN, 0};
            if (::poll(&p, 1, 1) > 0 && (p.revents & POLLIN)) {
                const ssize_t n = ::read(master, buf.data(), buf.size());
                if (n > 0) device.receive(std::span<const uint8_t>(buf.data(), static_cast<std::size_t>(n)), send);
            }
            device.on_tick();
            pipeline->tick(0.0f);
        }
    });
    {
        Client c(open_transport("serial:" + path + "@921600"));
        EXPECT_EQ(c.address(), "serial:" + path + "@921600");
        EXPECT_STREQ(c.hello().board.data(), "pty-board");
        const link::LimitsParams lim{reference::params().limits};
        c.set(lim);
        EXPECT_TRUE(c.get<link::LimitsParams>() == lim);
        c.arm();
        EXPECT_TRUE(c.status().armed);
    }
    stop = true;
    server.join();
    ::close(master);
}

}  // namespace
