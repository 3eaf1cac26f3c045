// The libusb transport (host/link/usb_transport.*) against an emulated board,
// with no USB hardware: umockdev (run under umockdev-wrapper, which preloads
// libumockdev-preload) gives libusb a sysfs tree and /dev/bus/usb nodes from
// a testbed, and forwards every usbdevfs ioctl on the board's node to the
// handler below. The handler plays the board:
//   - descriptors and EP0 requests come from the firmware's own chapter-9
//     code (firmware/usb/control.hpp + descriptors.hpp): the kernel's
//     enumeration (SET_ADDRESS, GET_DESCRIPTOR, SET_CONFIGURATION) is replayed
//     through it to make the sysfs "descriptors" file, and libusb's string
//     requests (serial, product) are control URBs answered by it, so a
//     descriptor change in the firmware shows up here;
//   - bulk OUT URBs on EP1 OUT (0x01) feed a link::Device<float> on the
//     reference pipeline (as tests/support/test_link_client.hpp), and its reply
//     frames complete the IN URBs queued on EP1 IN (0x81);
//   - an unplug completes the queued URBs with -ESHUTDOWN and answers every
//     later request with ENODEV, as the kernel's usbfs does.
//
// What umockdev cannot emulate, and what is therefore not tested here:
//   - POLLERR on the device fd after an unplug: umockdev's USB nodes are
//     plain files, always "writable" to poll(). A kernel signals the unplug
//     that way and libusb then completes every transfer with NO_DEVICE; here
//     the same status comes from the -ESHUTDOWN URBs and from the ENODEV
//     answers (submit); with the URBs left hanging, the transport's
//     read()-timeout probe sees the device gone (its sysfs entry removed).
//     For the same reason libusb's event loop polls REAPURBNDELAY
//     continuously; the handler sleeps 0.3 ms on an empty reap to keep that
//     from eating a CPU.
//   - USB packet timing: an IN URB is completed with whatever reply bytes
//     are waiting (a real board ends a transfer with a short packet).
//   - Access denied is a plain file permission on the node (chmod 600), so
//     as root (CI containers) that check runs in a forked child that has
//     dropped to uid/gid 65534.
//   - Transfer timeouts, STALL recovery and a kernel driver bound to the
//     interface.
#include <gtest/gtest.h>
#include <sys/ioctl.h>
#include <linux/usbdevice_fs.h>
#include <grp.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <umockdev.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "link/usb_transport.hpp"
#include "piezoloop/link/device.hpp"
#include "piezoloop/reference_stage.hpp"
#include "usb/control.hpp"
#include "usb/descriptors.hpp"

namespace {

using namespace piezoloop;
using piezoloop::hostlink::LinkError;

// ---- the emulated board -------------------------------------------------------

struct EmuHw {
    bool configured = false;
    bool stall_in = false, stall_out = false;
    void set_address(uint8_t) {}
    void configure_endpoints(bool on) {
        configured = on;
        stall_in = stall_out = false;
    }
    void set_endpoint_stall(uint8_t ep, bool stall) { (ep & 0x80 ? stall_in : stall_out) = stall; }
    bool endpoint_stalled(uint8_t ep) const { return (ep & 0x80) ? stall_in : stall_out; }
    usb::ControlReply vendor_setup(const usb::SetupPacket&, uint8_t*, std::size_t) {
        return usb::ControlReply::stall();  // as the firmware: the link runs on the bulk endpoints
    }
    void vendor_data_out(const usb::SetupPacket&, const uint8_t*, std::size_t) {}
};

// usbfs capabilities the emulated kernel reports: zero-length packets, bulk
// continuation, no packet size limit, scatter-gather (libusb then submits
// each bulk transfer as one URB, as on an xHCI controller).
constexpr uint32_t kCaps = USBDEVFS_CAP_ZERO_PACKET | USBDEVFS_CAP_BULK_CONTINUATION |
                           USBDEVFS_CAP_NO_PACKET_SIZE_LIM | USBDEVFS_CAP_BULK_SCATTER_GATHER;

class EmulatedBoard {
public:
    EmulatedBoard(std::string serial, int devnum)
        : serial_(std::move(serial)),
          product_("piezoloop servo (emulated)"),
          devnum_(devnum),
          ctrl_(hw_, usb::DeviceIdentity{}, "piezoloop", product_.c_str(), serial_.c_str(),
                usb::AddressTiming::kAtSetup),
          pipeline_(std::make_unique<link::Device<float>::PipelineType>(reference::setup())),
          device_(std::make_unique<link::Device<float>>(*pipeline_,
                                                       link::DeviceInfo{"emulated", "test", serial_.c_str()})) {
        // What the kernel does at enumeration, through the firmware's EP0 code.
        EXPECT_EQ(control(0x00, 5, static_cast<uint16_t>(devnum), 0, 0, nullptr), 0);  // SET_ADDRESS
        uint8_t buf[256];
        const int n_dev = control(0x80, 6, 0x0100, 0, 18, buf);                        // device descriptor
        EXPECT_EQ(n_dev, 18);
        descriptors_.assign(buf, buf + n_dev);
        const int n_cfg = control(0x80, 6, 0x0200, 0, 255, buf);                       // configuration
        EXPECT_EQ(n_cfg, static_cast<int>(usb::kConfigurationTotalLength));
        descriptors_.insert(descriptors_.end(), buf, buf + n_cfg);
        EXPECT_EQ(control(0x00, 9, usb::kConfigurationValue, 0, 0, nullptr), 0);      // SET_CONFIGURATION
        EXPECT_TRUE(hw_.configured);
    }
    ~EmulatedBoard() {
        for (auto& kv : clients_) drop(kv.second);
        if (handler_ != nullptr) g_object_unref(handler_);
    }

    const std::string& serial() const { return serial_; }
    const std::vector<uint8_t>& descriptors() const { return descriptors_; }
    std::string devnode() const {
        char s[32];
        std::snprintf(s, sizeof s, "/dev/bus/usb/001/%03d", devnum_);
        return s;
    }
    int devnum() const { return devnum_; }
    std::string syspath;

    // Adds the board to the testbed below the root hub and serves its node.
    void plug(UMockdevTestbed* tb, const std::string& hub_syspath, int port) {
        const std::string name = "1-" + std::to_string(port);
        const std::string devnum = std::to_string(devnum_);
        char busdev[16], dev[16];
        std::snprintf(busdev, sizeof busdev, "%03d", devnum_);
        std::snprintf(dev, sizeof dev, "189:%d", devnum_ - 1);
        gchar* p = umockdev_testbed_add_device(
            tb, "usb", name.c_str(), hub_syspath.c_str(),
            // sysfs attributes (what libusb and udev rules read)
            "busnum", "1", "devnum", devnum.c_str(), "speed", "12", "bConfigurationValue", "1",
            "idVendor", "1209", "idProduct", "0001", "serial", serial_.c_str(), "product", product_.c_str(),
            "manufacturer", "piezoloop", "dev", dev, nullptr,
            // udev properties
            "DEVTYPE", "usb_device", "DEVNAME", devnode().c_str(), "BUSNUM", "001", "DEVNUM", busdev, "ID_VENDOR_ID",
            "1209", "ID_MODEL_ID", "0001", "ID_SERIAL_SHORT", serial_.c_str(), nullptr);
        syspath = p;
        g_free(p);
        // add_device() records the node's major:minor but creates no file for
        // it (only add_from_string's "N:" lines do): an empty regular file is
        // what umockdev uses for USB nodes.
        gchar* root = umockdev_testbed_get_root_dir(tb);
        const std::string node = std::string(root) + devnode();
        g_free(root);
        ASSERT_EQ(g_mkdir_with_parents(node.substr(0, node.rfind('/')).c_str(), 0755), 0);
        ASSERT_TRUE(g_file_set_contents(node.c_str(), "", 0, nullptr));
        umockdev_testbed_set_attribute_binary(tb, syspath.c_str(), "descriptors",
                                              const_cast<guint8*>(descriptors_.data()),
                                              static_cast<gint>(descriptors_.size()));
        handler_ = umockdev_ioctl_base_new();
        g_signal_connect(handler_, "handle-ioctl", G_CALLBACK(&EmulatedBoard::on_ioctl), this);
        GError* error = nullptr;
        ASSERT_TRUE(umockdev_testbed_attach_ioctl(tb, devnode().c_str(), handler_, &error))
            << (error != nullptr ? error->message : "");
    }

    // The cable is pulled: the kernel fails the queued URBs and every later
    // request, then udev reports the removal and the sysfs entry goes.
    // fail_queued = false: the queued URBs are never completed (a kernel
    // without reap-after-disconnect whose POLLERR libusb missed, or a hung
    // host controller), so only the device's disappearance tells.
    void unplug(UMockdevTestbed* tb, bool fail_queued = true) {
        {
            std::lock_guard lock(m_);
            unplugged_ = true;
            fail_queued_ = fail_queued;
        }
        umockdev_testbed_uevent(tb, syspath.c_str(), "remove");
        umockdev_testbed_remove_device(tb, syspath.c_str());
    }

    struct Stats {
        int claims = 0, releases = 0, max_in_queued = 0, out_urbs = 0, control_urbs = 0;
        std::size_t out_bytes = 0;
        bool claimed = false;
        std::vector<unsigned long> unknown_ioctls;
    };
    Stats stats() {
        std::lock_guard lock(m_);
        return stats_;
    }

private:
    struct Urb {
        UMockdevIoctlData* urb;  // our reference
        UMockdevIoctlData* buf;  // child of urb (owned by it)
    };

    struct ClientState {
        std::deque<Urb> pending_in;                // IN URBs waiting for reply bytes
        std::deque<UMockdevIoctlData*> completed;  // reapable, oldest first (our references)
    };
    static void drop(ClientState& st) {
        for (Urb& u : st.pending_in) g_object_unref(u.urb);
        for (UMockdevIoctlData* u : st.completed) g_object_unref(u);
        st.pending_in.clear();
        st.completed.clear();
    }

    static usbdevfs_urb* urb_of(UMockdevIoctlData* d) { return reinterpret_cast<usbdevfs_urb*>(d->data); }

    // An EP0 request straight into the firmware's handler (enumeration).
    int control(uint8_t type, uint8_t request, uint16_t value, uint16_t index, uint16_t length, uint8_t* out) {
        const uint8_t raw[8] = {type,
                                request,
                                static_cast<uint8_t>(value & 0xFF),
                                static_cast<uint8_t>(value >> 8),
                                static_cast<uint8_t>(index & 0xFF),
                                static_cast<uint8_t>(index >> 8),
                                static_cast<uint8_t>(length & 0xFF),
                                static_cast<uint8_t>(length >> 8)};
        const usb::ControlReply r = ctrl_.setup(usb::SetupPacket::parse(raw));
        if (r.kind == usb::ControlReply::Kind::kStall) return -1;
        int n = 0;
        if (r.kind == usb::ControlReply::Kind::kDataIn && out != nullptr) {
            n = r.length;
            std::memcpy(out, r.data, static_cast<std::size_t>(n));
        }
        ctrl_.status_stage_done();
        return n;
    }

    static gboolean on_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
        static_cast<EmulatedBoard*>(self)->handle(client);
        return TRUE;
    }

    void complete(UMockdevIoctlClient* client, long result, int err) { umockdev_ioctl_client_complete(client, result, err); }

    void handle(UMockdevIoctlClient* client) {
        const unsigned long request = umockdev_ioctl_client_get_request(client);
        UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
        std::unique_lock lock(m_);
        // URBs belong to the open file (libusb device handle) that submitted
        // them, as in usbfs: each connection to the node is one client.
        ClientState& me = clients_[client];
        if (unplugged_) {
            // Queued URBs end with -ESHUTDOWN (reapable once), then ENODEV.
            for (auto& [c, st] : clients_) {
                if (!fail_queued_) break;
                for (Urb& u : st.pending_in) {
                    urb_of(u.urb)->status = -ESHUTDOWN;
                    urb_of(u.urb)->actual_length = 0;
                    st.completed.push_back(u.urb);
                }
                st.pending_in.clear();
            }
            if ((request == USBDEVFS_REAPURBNDELAY || request == USBDEVFS_REAPURB) && !me.completed.empty()) {
                reap(client, arg, me);
                return;
            }
            complete(client, -1, ENODEV);
            return;
        }
        GError* error = nullptr;
        switch (request) {
            case USBDEVFS_GET_CAPABILITIES: {
                // libusb's first request on a newly opened handle: a client
                // object at a recycled address starts clean.
                drop(me);
                UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(uint32_t), &error);
                std::memcpy(d->data, &kCaps, sizeof kCaps);
                complete(client, 0, 0);
                return;
            }
            case USBDEVFS_CLAIMINTERFACE:
            case USBDEVFS_RELEASEINTERFACE: {
                UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(unsigned int), &error);
                unsigned int iface = 0;
                std::memcpy(&iface, d->data, sizeof iface);
                if (iface != usb::kInterfaceNumber) {
                    complete(client, -1, EINVAL);
                    return;
                }
                if (request == USBDEVFS_CLAIMINTERFACE) {
                    if (claimed_by_ != nullptr && claimed_by_ != client) {
                        complete(client, -1, EBUSY);
                        return;
                    }
                    ++stats_.claims;
                    claimed_by_ = client;
                } else {
                    if (claimed_by_ != client) {
                        complete(client, -1, EINVAL);
                        return;
                    }
                    ++stats_.releases;
                    claimed_by_ = nullptr;
                }
                stats_.claimed = claimed_by_ != nullptr;
                complete(client, 0, 0);
                return;
            }
            case USBDEVFS_SUBMITURB: submit(client, arg, me); return;
            case USBDEVFS_REAPURB:
            case USBDEVFS_REAPURBNDELAY:
                if (me.completed.empty()) {
                    lock.unlock();
                    g_usleep(300);  // see the header: poll() cannot wait for us
                    complete(client, -1, EAGAIN);
                    return;
                }
                reap(client, arg, me);
                return;
            case USBDEVFS_DISCARDURB: {
                // The argument is the URB's address in the client.
                gulong addr = 0;
                std::memcpy(&addr, arg->data, sizeof addr);
                for (auto it = me.pending_in.begin(); it != me.pending_in.end(); ++it) {
                    if (it->urb->client_addr != addr) continue;
                    urb_of(it->urb)->status = -ENOENT;  // the kernel's "unlinked"
                    urb_of(it->urb)->actual_length = 0;
                    me.completed.push_back(it->urb);
                    me.pending_in.erase(it);
                    complete(client, 0, 0);
                    return;
                }
                complete(client, -1, EINVAL);
                return;
            }
            case USBDEVFS_CLEAR_HALT: {
                UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(unsigned int), &error);
                unsigned int ep = 0;
                std::memcpy(&ep, d->data, sizeof ep);
                hw_.set_endpoint_stall(static_cast<uint8_t>(ep), false);
                complete(client, 0, 0);
                return;
            }
            case USBDEVFS_GET_SPEED: complete(client, 2 /* USB_SPEED_FULL */, 0); return;
            default:
                stats_.unknown_ioctls.push_back(request);
                complete(client, -1, ENOTTY);
                return;
        }
    }

    void submit(UMockdevIoctlClient* client, UMockdevIoctlData* arg, ClientState& me) {
        GError* error = nullptr;
        UMockdevIoctlData* urb = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_urb), &error);
        if (urb == nullptr) {
            complete(client, -1, EFAULT);
            return;
        }
        usbdevfs_urb* u = urb_of(urb);
        UMockdevIoctlData* buf = nullptr;
        if (u->buffer_length > 0)
            buf = umockdev_ioctl_data_resolve(urb, offsetof(usbdevfs_urb, buffer),
                                              static_cast<gsize>(u->buffer_length), &error);
        if (u->type == USBDEVFS_URB_TYPE_CONTROL && u->endpoint == 0 && buf != nullptr && u->buffer_length >= 8) {
            ++stats_.control_urbs;
            const usb::SetupPacket s = usb::SetupPacket::parse(buf->data);
            const usb::ControlReply r = ctrl_.setup(s);
            u->actual_length = 0;
            u->status = 0;
            switch (r.kind) {
                case usb::ControlReply::Kind::kStall: u->status = -EPIPE; break;
                case usb::ControlReply::Kind::kDataIn: {
                    const int n = std::min<int>(r.length, u->buffer_length - 8);
                    std::memcpy(buf->data + 8, r.data, static_cast<std::size_t>(n));
                    u->actual_length = n;
                    ctrl_.status_stage_done();
                    break;
                }
                case usb::ControlReply::Kind::kDataOut:
                    ctrl_.data_out_done(buf->data + 8, s.wLength);
                    u->actual_length = s.wLength;
                    ctrl_.status_stage_done();
                    break;
                case usb::ControlReply::Kind::kStatusIn: ctrl_.status_stage_done(); break;
            }
            me.completed.push_back(static_cast<UMockdevIoctlData*>(g_object_ref(urb)));
            complete(client, 0, 0);
            return;
        }
        if (u->type != USBDEVFS_URB_TYPE_BULK ||
            (u->endpoint != usb::kBulkOutEndpoint && u->endpoint != usb::kBulkInEndpoint) || !hw_.configured) {
            complete(client, -1, ENOENT);  // no such endpoint in the active configuration
            return;
        }
        if (claimed_by_ != client) {
            complete(client, -1, EBUSY);  // the interface belongs to another open file
            return;
        }
        if (u->endpoint == usb::kBulkOutEndpoint) {
            ++stats_.out_urbs;
            const std::size_t n = static_cast<std::size_t>(u->buffer_length);
            stats_.out_bytes += n;
            if (n > 0)
                device_->receive(std::span<const uint8_t>(buf->data, n), [this](std::span<const uint8_t> frame) {
                    to_host_.insert(to_host_.end(), frame.begin(), frame.end());
                });
            // Time passes on the board: one control tick per OUT transfer
            // (a staged parameter set is swapped in).
            device_->on_tick();
            pipeline_->tick(sample_zero<float>());
            u->actual_length = u->buffer_length;
            u->status = 0;
            me.completed.push_back(static_cast<UMockdevIoctlData*>(g_object_ref(urb)));
        } else {
            me.pending_in.push_back({static_cast<UMockdevIoctlData*>(g_object_ref(urb)), buf});
            stats_.max_in_queued = std::max(stats_.max_in_queued, static_cast<int>(me.pending_in.size()));
        }
        serve_in(me);
        complete(client, 0, 0);
    }

    // Reply bytes complete the oldest queued IN URB.
    void serve_in(ClientState& me) {
        while (!to_host_.empty() && !me.pending_in.empty()) {
            Urb u = me.pending_in.front();
            me.pending_in.pop_front();
            usbdevfs_urb* p = urb_of(u.urb);
            const std::size_t n = std::min(static_cast<std::size_t>(p->buffer_length), to_host_.size());
            std::copy_n(to_host_.begin(), n, u.buf->data);
            to_host_.erase(to_host_.begin(), to_host_.begin() + static_cast<std::ptrdiff_t>(n));
            p->actual_length = static_cast<int>(n);
            p->status = 0;
            me.completed.push_back(u.urb);
        }
    }

    // REAPURB(NDELAY): the argument points to the client's URB pointer, which
    // gets the oldest completed URB (written back with its status, length
    // and, for IN, its data when the ioctl completes).
    void reap(UMockdevIoctlClient* client, UMockdevIoctlData* arg, ClientState& me) {
        GError* error = nullptr;
        UMockdevIoctlData* slot = umockdev_ioctl_data_resolve(arg, 0, sizeof(void*), &error);
        UMockdevIoctlData* urb = me.completed.front();
        me.completed.pop_front();
        umockdev_ioctl_data_set_ptr(slot, 0, urb);
        g_object_unref(urb);  // slot holds it now
        complete(client, 0, 0);
    }

    std::string serial_, product_;
    int devnum_;
    EmuHw hw_;
    usb::ControlHandler<EmuHw> ctrl_;
    std::vector<uint8_t> descriptors_;
    std::unique_ptr<link::Device<float>::PipelineType> pipeline_;
    std::unique_ptr<link::Device<float>> device_;
    UMockdevIoctlBase* handler_ = nullptr;

    std::mutex m_;
    bool unplugged_ = false;
    bool fail_queued_ = true;
    std::deque<uint8_t> to_host_;
    std::map<UMockdevIoctlClient*, ClientState> clients_;
    UMockdevIoctlClient* claimed_by_ = nullptr;
    Stats stats_;
};

// ---- the test bed ---------------------------------------------------------------

class UsbTransportTest : public ::testing::Test {
protected:
    void SetUp() override {
        const char* preload = std::getenv("LD_PRELOAD");
        if (preload == nullptr || std::strstr(preload, "umockdev-preload") == nullptr)
            GTEST_SKIP() << "not under umockdev-wrapper (LD_PRELOAD of libumockdev-preload); CTest runs it so";
        tb_ = umockdev_testbed_new();
        // The root hub of bus 1 (another VID/PID: never selected).
        gchar* p = umockdev_testbed_add_device(tb_, "usb", "usb1", nullptr, "busnum", "1", "devnum", "1", "speed",
                                               "480", "bConfigurationValue", "1", "idVendor", "1d6b", "idProduct",
                                               "0002", "dev", "189:0", nullptr, "DEVTYPE", "usb_device", "DEVNAME",
                                               "/dev/bus/usb/001/001", "BUSNUM", "001", "DEVNUM", "001", nullptr);
        hub_ = p;
        g_free(p);
        // Device descriptor 1d6b:0002, hub class, one configuration (9 + 9 + 7).
        static const guint8 kHub[] = {18, 1, 0x00, 0x02, 9, 0, 1, 64, 0x6b, 0x1d, 0x02, 0x00, 0x00, 0x06, 3, 2, 1, 1,
                                      9, 2, 25, 0, 1, 1, 0, 0xE0, 0,
                                      9, 4, 0, 0, 1, 9, 0, 0, 0,
                                      7, 5, 0x81, 3, 4, 0, 12};
        umockdev_testbed_set_attribute_binary(tb_, hub_.c_str(), "descriptors", const_cast<guint8*>(kHub),
                                              sizeof kHub);
    }
    void TearDown() override {
        boards_.clear();
        if (tb_ != nullptr) g_object_unref(tb_);
    }

    EmulatedBoard& add_board(const std::string& serial) {
        const int n = static_cast<int>(boards_.size());
        boards_.push_back(std::make_unique<EmulatedBoard>(serial, 2 + n));
        boards_.back()->plug(tb_, hub_, 1 + n);
        return *boards_.back();
    }

    UMockdevTestbed* tb_ = nullptr;
    std::string hub_;
    std::vector<std::unique_ptr<EmulatedBoard>> boards_;
};

// ---- a minimal protocol client over the transport -------------------------------

struct Reply {
    link::FrameHeader header{};
    std::vector<uint8_t> body;
    template <class M>
    M as() const {
        M m{};
        EXPECT_EQ(header.type, static_cast<uint8_t>(M::kType));
        EXPECT_EQ(link::decode_body(std::span<const uint8_t>(body), m), link::DecodeResult::kOk);
        return m;
    }
};

class Client {
public:
    explicit Client(hostlink::Transport& t) : t_(t) {}
    template <class M>
    Reply request(const M& m) {
        std::vector<uint8_t> frame(link::kMaxFrameSize);
        const uint16_t seq = ++seq_;
        frame.resize(link::encode_message(m, seq, frame));
        EXPECT_GT(frame.size(), 0u);
        t_.write(frame);
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
        while (std::chrono::steady_clock::now() < deadline) {
            uint8_t buf[4096];
            const std::size_t n = t_.read(buf, std::chrono::milliseconds(100));
            std::vector<Reply> got;
            rx_.feed(std::span<const uint8_t>(buf, n), [&](std::span<const uint8_t> payload) {
                Reply r;
                r.header = link::parse_header(payload);
                r.body.assign(payload.begin() + link::kHeaderSize, payload.end());
                got.push_back(std::move(r));
            });
            for (Reply& r : got)
                if (r.header.seq == seq) return r;
        }
        ADD_FAILURE() << "no reply to request " << seq;
        return {};
    }

private:
    hostlink::Transport& t_;
    link::FrameDecoder rx_;
    uint16_t seq_ = 0;
};

template <class F>
std::string error_of(F&& f) {
    try {
        f();
    } catch (const LinkError& e) {
        return e.what();
    }
    return "(no LinkError)";
}

// ---- tests ------------------------------------------------------------------------

TEST_F(UsbTransportTest, DescriptorsComeFromTheFirmware) {
    EmulatedBoard& b = add_board("SN-A");
    // Independent of the emulation: the firmware's compile-time descriptors.
    const auto dev = usb::device_descriptor(usb::DeviceIdentity{});
    const auto cfg = usb::configuration_descriptor(usb::DeviceIdentity{});
    std::vector<uint8_t> expected(dev.begin(), dev.end());
    expected.insert(expected.end(), cfg.begin(), cfg.end());
    EXPECT_EQ(b.descriptors(), expected);
}

TEST_F(UsbTransportTest, ProtocolSessionOverBulkEndpoints) {
    EmulatedBoard& b = add_board("SN-A");
    auto t = hostlink::open_usb("");
    EXPECT_EQ(t->address(), "usb:SN-A");
    EXPECT_TRUE(b.stats().claimed);
    Client c(*t);

    const auto hello = c.request(link::Hello{}).as<link::HelloReply>();
    EXPECT_EQ(hello.protocol_version, link::kProtocolVersion);
    EXPECT_STREQ(hello.serial.data(), "SN-A");  // the board's own serial, through EP1
    EXPECT_STREQ(hello.board.data(), "emulated");

    const auto before = c.request(link::GetStatus{}).as<link::StatusReply>();
    EXPECT_EQ(before.link.frames_ok, 2u);  // Hello and this request, intact
    EXPECT_EQ(before.link.bad_crc + before.link.bad_cobs + before.link.truncated, 0u);

    const PipelineParams p = reference::params(true, true, false);
    link::LimitsParams lim{p.limits};
    lim.limits.u_max_V = 7.5f;  // a value the board did not start with
    const Reply ack = c.request(link::SetParams<link::LimitsParams>{lim});
    ASSERT_EQ(ack.header.type, static_cast<uint8_t>(link::MsgType::kAck));
    EXPECT_EQ(ack.as<link::Ack>().request_type, static_cast<uint8_t>(link::MsgType::kSetParams));
    // Read back: the board holds what crossed the bulk endpoints.
    const auto back = c.request(link::GetParams{link::ParamGroup::kLimits}).as<link::ParamsReply<link::LimitsParams>>();
    EXPECT_EQ(back.value, lim);
    const auto after = c.request(link::GetStatus{}).as<link::StatusReply>();
    EXPECT_EQ(after.swaps, before.swaps + 1);  // swapped in at the board's next tick
    EXPECT_EQ(after.link.frames_ok, 5u);

    // A rejected value comes back as an Error reply, not a transport error.
    lim.limits.u_max_V = 1e3f;  // beyond the hard limit
    const Reply err = c.request(link::SetParams<link::LimitsParams>{lim});
    ASSERT_EQ(err.header.type, static_cast<uint8_t>(link::MsgType::kError));
    EXPECT_STREQ(err.as<link::ErrorReply>().field.data(), "u_max_V");

    // Several IN transfers were queued at once (the transport keeps 4).
    EXPECT_GE(b.stats().max_in_queued, 4);
    EXPECT_TRUE(b.stats().unknown_ioctls.empty());
    t.reset();
    EXPECT_EQ(b.stats().releases, 1);  // released on destruction
    EXPECT_FALSE(b.stats().claimed);
}

TEST_F(UsbTransportTest, LargeWritesAndManyReplies) {
    add_board("SN-A");
    auto t = hostlink::open_usb("SN-A");
    Client c(*t);
    // 600 requests back to back in one write (> 4 KiB of frames): all
    // answered, in order, through the queued IN transfers.
    std::vector<uint8_t> burst;
    for (uint16_t s = 1; s <= 600; ++s) {
        std::vector<uint8_t> f(link::kMaxFrameSize);
        f.resize(link::encode_message(link::GetStatus{}, s, f));
        burst.insert(burst.end(), f.begin(), f.end());
    }
    ASSERT_GT(burst.size(), 4096u);
    t->write(burst);
    link::FrameDecoder rx;
    std::vector<uint16_t> seqs;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (seqs.size() < 600 && std::chrono::steady_clock::now() < deadline) {
        uint8_t buf[1000];
        const std::size_t n = t->read(buf, std::chrono::milliseconds(100));
        rx.feed(std::span<const uint8_t>(buf, n),
                [&](std::span<const uint8_t> payload) { seqs.push_back(link::parse_header(payload).seq); });
    }
    ASSERT_EQ(seqs.size(), 600u);
    for (std::size_t i = 0; i < seqs.size(); ++i) EXPECT_EQ(seqs[i], i + 1);
    EXPECT_EQ(rx.counters().bad_crc + rx.counters().bad_cobs, 0u);
}

TEST_F(UsbTransportTest, SelectionBySerialAndListing) {
    add_board("SN-A");
    add_board("SN-B");
    const auto boards = hostlink::list_usb_boards();
    ASSERT_EQ(boards.size(), 2u);  // the root hub (1d6b:0002) is not listed
    EXPECT_EQ(boards[0].serial, "SN-A");
    EXPECT_EQ(boards[0].bus_port, "1-1");
    EXPECT_EQ(boards[1].serial, "SN-B");
    EXPECT_EQ(boards[1].bus_port, "1-2");
    EXPECT_EQ(boards[1].product, "piezoloop servo (emulated)");
    EXPECT_EQ(boards[1].vid, 0x1209);
    EXPECT_EQ(boards[1].pid, 0x0001);

    // Two boards and no serial: refused, naming both.
    const std::string several = error_of([] { hostlink::open_usb(""); });
    EXPECT_NE(several.find("SN-A"), std::string::npos) << several;
    EXPECT_NE(several.find("SN-B"), std::string::npos) << several;
    EXPECT_NE(several.find("usb:SERIAL"), std::string::npos) << several;

    // By serial: the one asked for answers Hello with its own serial.
    auto t = hostlink::open_usb("SN-B");
    EXPECT_EQ(t->address(), "usb:SN-B");
    Client c(*t);
    EXPECT_STREQ(c.request(link::Hello{}).as<link::HelloReply>().serial.data(), "SN-B");
    EXPECT_TRUE(boards_[1]->stats().claimed);
    EXPECT_FALSE(boards_[0]->stats().claimed);

    const std::string missing = error_of([] { hostlink::open_usb("SN-C"); });
    EXPECT_NE(missing.find("no piezoloop USB board (1209:0001) with serial number SN-C"), std::string::npos) << missing;
}

TEST_F(UsbTransportTest, DuplicateSerialsAreRefused) {
    // Two NUCLEO boards with today's fixed firmware serial "0001".
    add_board("0001");
    add_board("0001");
    const std::string e = error_of([] { hostlink::open_usb("0001"); });
    EXPECT_NE(e.find("2 piezoloop USB board (1209:0001)s report serial number 0001 (0001 at 1-1, 0001 at 1-2)"),
              std::string::npos)
        << e;
    EXPECT_FALSE(boards_[0]->stats().claimed);
    EXPECT_FALSE(boards_[1]->stats().claimed);
}

TEST_F(UsbTransportTest, NoBoard) {
    EXPECT_TRUE(hostlink::list_usb_boards().empty());
    const std::string e = error_of([] { hostlink::open_usb(""); });
    EXPECT_NE(e.find("no piezoloop USB board (1209:0001) found"), std::string::npos) << e;
}

TEST_F(UsbTransportTest, UnplugMidSession) {
    EmulatedBoard& b = add_board("SN-A");
    auto t = hostlink::open_usb("");
    Client c(*t);
    ASSERT_EQ(c.request(link::Hello{}).header.type, static_cast<uint8_t>(link::MsgType::kHelloReply));
    b.unplug(tb_);
    // The queued IN transfers end with NO_DEVICE: read() says so at once.
    uint8_t buf[64];
    const auto t0 = std::chrono::steady_clock::now();
    const std::string r = error_of([&] { t->read(buf, std::chrono::milliseconds(2000)); });
    EXPECT_EQ(r, "usb:SN-A: device unplugged");
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(1500));
    const std::string w = error_of([&] {
        const uint8_t zero[1] = {0};
        t->write(zero);
    });
    EXPECT_EQ(w, "usb:SN-A: device unplugged");
    t.reset();  // closes cleanly with the device gone
    EXPECT_TRUE(hostlink::list_usb_boards().empty());
}

TEST_F(UsbTransportTest, UnplugSeenWithoutTransferCompletion) {
    EmulatedBoard& b = add_board("SN-A");
    auto t = hostlink::open_usb("");
    Client c(*t);
    ASSERT_EQ(c.request(link::Hello{}).header.type, static_cast<uint8_t>(link::MsgType::kHelloReply));
    b.unplug(tb_, false);
    // The IN transfers stay queued; a read that times out checks the device
    // (libusb_get_configuration: NO_DEVICE once its sysfs entry is gone).
    uint8_t buf[64];
    const std::string r = error_of([&] {
        for (int i = 0; i < 10; ++i) t->read(buf, std::chrono::milliseconds(100));
    });
    EXPECT_EQ(r, "usb:SN-A: device unplugged");
    const auto t0 = std::chrono::steady_clock::now();
    t.reset();  // the stuck transfers are dropped by libusb_close, after a bounded wait
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(3));
}

TEST_F(UsbTransportTest, WriteAfterUnplugWithoutRead) {
    EmulatedBoard& b = add_board("SN-A");
    auto t = hostlink::open_usb("SN-A");
    b.unplug(tb_);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::string w = error_of([&] {
        const uint8_t zero[1] = {0};
        t->write(zero);
    });
    EXPECT_EQ(w, "usb:SN-A: device unplugged");
}

// Runs f as an unprivileged user when the test is root (root ignores file
// permissions): in a forked child with uid/gid 65534 ("nobody"), which
// reports f's result through a pipe. Only open()/sysfs reads happen in the
// child; the testbed's ioctl thread is not needed there.
template <class F>
std::string as_unprivileged(F&& f) {
    if (geteuid() != 0) return f();
    int fds[2];
    if (pipe(fds) != 0) return "(pipe failed)";
    const pid_t pid = fork();
    if (pid == 0) {
        close(fds[0]);
        std::string out = "(could not drop privileges)";
        try {
            if (setgroups(0, nullptr) == 0 && setgid(65534) == 0 && setuid(65534) == 0) out = f();
        } catch (const std::exception& e) {
            out = std::string("(exception) ") + e.what();
        }
        const ssize_t written = ::write(fds[1], out.data(), out.size());
        _exit(written == static_cast<ssize_t>(out.size()) ? 0 : 1);
    }
    close(fds[1]);
    std::string out;
    char buf[512];
    for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;) out.append(buf, static_cast<std::size_t>(n));
    close(fds[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    return out;
}

TEST_F(UsbTransportTest, AccessDenied) {
    EmulatedBoard& b = add_board("SN-A");
    gchar* root = umockdev_testbed_get_root_dir(tb_);
    const std::string root_dir = root;
    g_free(root);
    // The testbed (mkdtemp, 0700) must be usable by the unprivileged user
    // (libudev's monitor socket is bound inside it); the node itself is not:
    // what a system without the udev rule looks like.
    ASSERT_EQ(chmod(root_dir.c_str(), 0777), 0);
    ASSERT_EQ(chmod((root_dir + b.devnode()).c_str(), 0), 0);
    // libumockdev-preload connects to the node's ioctl socket on every open
    // of a /dev path and exits if it cannot: let the unprivileged child in.
    ASSERT_EQ(chmod((root_dir + "/ioctl" + b.devnode()).c_str(), 0666), 0);
    const std::string e = as_unprivileged([] { return error_of([] { hostlink::open_usb(""); }); });
    EXPECT_NE(e.find("usb: access denied to the piezoloop USB board (1209:0001) at 1-1 (/dev/bus/usb/001/002"),
              std::string::npos)
        << e;
    EXPECT_NE(e.find("60-piezoloop.rules"), std::string::npos) << e;
    EXPECT_NE(e.find("USB access (udev)"), std::string::npos) << e;
    const std::string listed = as_unprivileged([] {
        const auto boards = hostlink::list_usb_boards();
        return boards.size() == 1 ? "serial=" + boards[0].serial + " product=" + boards[0].product
                                  : "boards: " + std::to_string(boards.size());
    });
    EXPECT_EQ(listed.rfind("serial= product=(cannot open /dev/bus/usb/001/002: LIBUSB_ERROR_ACCESS", 0), 0u)
        << listed;
    EXPECT_NE(listed.find("USB access (udev)"), std::string::npos) << listed;
}

}  // namespace
