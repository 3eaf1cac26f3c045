// libusb transport to the vendor-bulk board: device selection, interface
// claim, queued IN transfers with an event thread, synchronous OUT writes.
#include "link/usb_transport.hpp"

#include <libusb.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <mutex>
#include <thread>
#include <utility>

// The board's identity and endpoints, shared with the firmware: header-only
// and freestanding, so the host includes it straight from firmware/.
#include "piezoloop/usb/descriptors.hpp"

namespace piezoloop::hostlink {

namespace {

constexpr usb::DeviceIdentity kIdentity{};
constexpr uint16_t kVid = kIdentity.vendor_id;
constexpr uint16_t kPid = kIdentity.product_id;
constexpr int kInterface = usb::kInterfaceNumber;
constexpr unsigned char kEpOut = usb::kBulkOutEndpoint;
constexpr unsigned char kEpIn = usb::kBulkInEndpoint;

// Four 4 KiB IN transfers: the host controller always has a buffer queued
// for the board, even while one completion is being handled, and each holds
// several 520-byte log frames (protocol.md section 8: 2 channels at 100 kHz
// are ~0.87 MB/s, ~212 transfers/s at 4 KiB). Multiples of the 64-byte
// packet size, so a transfer never overflows mid-packet.
constexpr int kInTransfers = 4;
constexpr int kInTransferSize = 4096;
static_assert(kInTransferSize % usb::kBulkMaxPacket == 0, "IN transfers must be whole packets");
// A board that does not take an OUT packet for this long is not reading.
constexpr unsigned kWriteTimeoutMs = 2000;
// read() timeouts check at most this often whether the device is still there.
constexpr auto kProbeInterval = std::chrono::milliseconds(200);

const char* const kUdevHint =
    "install the udev rule: sudo install -m 644 tools/udev/60-piezoloop.rules /etc/udev/rules.d/ && "
    "sudo udevadm control --reload && sudo udevadm trigger, then unplug and replug the board "
    "(docs/boards.md, \"USB access (udev)\")";

std::string err_name(int r) { return libusb_error_name(r); }

std::string vid_pid() {
    char s[16];
    std::snprintf(s, sizeof s, "%04x:%04x", kVid, kPid);
    return s;
}

std::string bus_port_of(libusb_device* dev) {
    uint8_t ports[8];
    const int n = libusb_get_port_numbers(dev, ports, static_cast<int>(sizeof ports));
    std::string s = std::to_string(libusb_get_bus_number(dev));
    for (int i = 0; i < n; ++i) s += (i == 0 ? "-" : ".") + std::to_string(ports[i]);
    if (n <= 0) s += ":" + std::to_string(libusb_get_device_address(dev));
    return s;
}

std::string node_of(libusb_device* dev) {
    char s[32];
    std::snprintf(s, sizeof s, "/dev/bus/usb/%03u/%03u", libusb_get_bus_number(dev), libusb_get_device_address(dev));
    return s;
}

std::string string_descriptor(libusb_device_handle* h, uint8_t index) {
    if (index == 0) return {};
    unsigned char buf[256];
    const int n = libusb_get_string_descriptor_ascii(h, index, buf, sizeof buf);
    if (n < 0) return {};
    return std::string(reinterpret_cast<const char*>(buf), static_cast<std::size_t>(n));
}

// One libusb context per transport / listing: libusb enumerates at init,
// so a fresh context sees the devices present now.
struct Context {
    libusb_context* ctx = nullptr;
    explicit Context(const std::string& who) {
        const int r = libusb_init(&ctx);
        if (r != 0)
            throw LinkError(who + ": libusb cannot start (" + err_name(r) +
                            "; is there a USB device filesystem, /dev/bus/usb, on this machine?)");
    }
    ~Context() {
        if (ctx != nullptr) libusb_exit(ctx);
    }
    libusb_context* release() { return std::exchange(ctx, nullptr); }
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;
};

struct DeviceList {
    libusb_device** list = nullptr;
    ssize_t count = 0;
    DeviceList(libusb_context* ctx, const std::string& who) {
        count = libusb_get_device_list(ctx, &list);
        if (count < 0) throw LinkError(who + ": cannot list USB devices (" + err_name(static_cast<int>(count)) + ")");
    }
    ~DeviceList() { libusb_free_device_list(list, 1); }
    DeviceList(const DeviceList&) = delete;
    DeviceList& operator=(const DeviceList&) = delete;
};

bool is_board(libusb_device* dev) {
    libusb_device_descriptor d{};
    return libusb_get_device_descriptor(dev, &d) == 0 && d.idVendor == kVid && d.idProduct == kPid;
}

class UsbTransport : public Transport {
public:
    UsbTransport(libusb_context* ctx, libusb_device_handle* h, std::string address)
        : ctx_(ctx), h_(h), address_(std::move(address)) {
        events_ = std::thread([this] { event_loop(); });
        std::lock_guard lock(m_);
        for (int i = 0; i < kInTransfers; ++i) {
            libusb_transfer* t = libusb_alloc_transfer(0);
            in_buf_.emplace_back(std::make_unique<unsigned char[]>(kInTransferSize));
            libusb_fill_bulk_transfer(t, h_, kEpIn, in_buf_.back().get(), kInTransferSize, &UsbTransport::in_done,
                                      this, 0 /* no timeout: IN waits for the board */);
            in_.push_back(t);
            const int r = libusb_submit_transfer(t);
            if (r == 0) {
                ++in_flight_;
            } else {
                note_failure_locked(r, "cannot queue IN transfers");
            }
        }
    }

    ~UsbTransport() override {
        {
            std::lock_guard lock(m_);
            stopping_ = true;
        }
        for (libusb_transfer* t : in_) libusb_cancel_transfer(t);  // NOT_FOUND for finished ones
        {
            // Cancelled transfers complete through the event thread. A
            // device that is gone may never complete them: bounded wait,
            // libusb_close() then drops them from libusb's lists.
            std::unique_lock lock(m_);
            cv_.wait_for(lock, std::chrono::seconds(1), [this] { return in_flight_ == 0 || events_dead_; });
        }
        quit_.store(true);
        libusb_interrupt_event_handler(ctx_);
        events_.join();
        libusb_release_interface(h_, kInterface);  // fails harmlessly once unplugged
        libusb_close(h_);
        for (libusb_transfer* t : in_) libusb_free_transfer(t);
        libusb_exit(ctx_);
    }

    UsbTransport(const UsbTransport&) = delete;
    UsbTransport& operator=(const UsbTransport&) = delete;

    void write(std::span<const uint8_t> bytes) override {
        if (bytes.empty()) return;
        {
            std::lock_guard lock(m_);
            throw_if_failed_locked();
        }
        struct Pending {
            UsbTransport* self;
            bool done = false;
        } pending{this};
        libusb_transfer* t = libusb_alloc_transfer(0);
        if (t == nullptr) throw LinkError(address_ + ": out of memory for a USB transfer");
        // libusb does not write to an OUT buffer; its API is not const.
        libusb_fill_bulk_transfer(
            t, h_, kEpOut, const_cast<unsigned char*>(bytes.data()), static_cast<int>(bytes.size()),
            [](libusb_transfer* tr) {
                auto* p = static_cast<Pending*>(tr->user_data);
                std::lock_guard lock(p->self->m_);
                p->done = true;
                p->self->cv_.notify_all();
            },
            &pending, kWriteTimeoutMs);
        const int r = libusb_submit_transfer(t);
        if (r != 0) {
            libusb_free_transfer(t);
            std::lock_guard lock(m_);
            note_failure_locked(r, "cannot submit the OUT transfer");
            throw_if_failed_locked();
            throw LinkError(address_ + ": cannot submit the OUT transfer (" + err_name(r) + ")");
        }
        std::unique_lock lock(m_);
        cv_.wait(lock, [&] { return pending.done || events_dead_; });
        if (!pending.done) {
            // No event thread any more: the transfer cannot complete, and must
            // not be freed while libusb still owns it.
            throw LinkError(address_ + ": USB event handling stopped (" + failure_ + ")");
        }
        const libusb_transfer_status status = t->status;
        const int sent = t->actual_length;
        libusb_free_transfer(t);
        if (status == LIBUSB_TRANSFER_COMPLETED && sent == static_cast<int>(bytes.size())) return;
        if (status == LIBUSB_TRANSFER_NO_DEVICE) gone_ = true;
        throw_if_failed_locked();
        const std::string progress = " (" + std::to_string(sent) + " of " + std::to_string(bytes.size()) + " bytes sent)";
        if (status == LIBUSB_TRANSFER_TIMED_OUT)
            throw LinkError(address_ + ": write timed out after " + std::to_string(kWriteTimeoutMs) +
                            " ms: the board does not read EP1 OUT" + progress);
        if (status == LIBUSB_TRANSFER_STALL) throw LinkError(address_ + ": EP1 OUT stalled" + progress);
        throw LinkError(address_ + ": write failed (" + std::string(libusb_error_name(status_error(status))) + ")" +
                        progress);
    }

    std::size_t read(std::span<uint8_t> buffer, std::chrono::milliseconds timeout) override {
        {
            std::unique_lock lock(m_);
            cv_.wait_for(lock, timeout, [this] { return !rx_.empty() || gone_ || !failure_.empty(); });
            if (!rx_.empty()) {
                const std::size_t n = std::min(buffer.size(), rx_.size());
                std::copy_n(rx_.begin(), n, buffer.begin());
                rx_.erase(rx_.begin(), rx_.begin() + static_cast<std::ptrdiff_t>(n));
                return n;
            }
            throw_if_failed_locked();
        }
        // Nothing arrived. On Linux an unplug normally completes the queued
        // transfers with NO_DEVICE; where it does not (no POLLERR on the
        // device fd, e.g. emulated devices), the device's disappearance is
        // seen here: get_configuration fails with NO_DEVICE once it is gone.
        const auto now = std::chrono::steady_clock::now();
        if (now - last_probe_ >= kProbeInterval) {
            last_probe_ = now;
            int configuration = 0;
            if (libusb_get_configuration(h_, &configuration) == LIBUSB_ERROR_NO_DEVICE) {
                std::lock_guard lock(m_);
                gone_ = true;
                throw_if_failed_locked();
            }
        }
        return 0;
    }

    std::string address() const override { return address_; }

private:
    static int status_error(libusb_transfer_status s) {
        switch (s) {
            case LIBUSB_TRANSFER_TIMED_OUT: return LIBUSB_ERROR_TIMEOUT;
            case LIBUSB_TRANSFER_STALL: return LIBUSB_ERROR_PIPE;
            case LIBUSB_TRANSFER_NO_DEVICE: return LIBUSB_ERROR_NO_DEVICE;
            case LIBUSB_TRANSFER_OVERFLOW: return LIBUSB_ERROR_OVERFLOW;
            case LIBUSB_TRANSFER_CANCELLED: return LIBUSB_ERROR_INTERRUPTED;
            default: return LIBUSB_ERROR_IO;
        }
    }

    void note_failure_locked(int libusb_error, const char* what) {
        if (libusb_error == LIBUSB_ERROR_NO_DEVICE) {
            gone_ = true;
        } else if (failure_.empty()) {
            failure_ = std::string(what) + " (" + err_name(libusb_error) + ")";
        }
        cv_.notify_all();
    }

    void throw_if_failed_locked() const {
        if (gone_) throw LinkError(address_ + ": device unplugged");
        if (!failure_.empty()) throw LinkError(address_ + ": " + failure_);
    }

    // Runs on the event thread. Completed IN data goes to rx_, and the
    // transfer is queued again at once (under m_, so the destructor's
    // stopping_ cannot be missed between the check and the resubmit).
    static void LIBUSB_CALL in_done(libusb_transfer* t) {
        auto* self = static_cast<UsbTransport*>(t->user_data);
        std::lock_guard lock(self->m_);
        --self->in_flight_;
        switch (t->status) {
            case LIBUSB_TRANSFER_COMPLETED:
            case LIBUSB_TRANSFER_TIMED_OUT:
                self->rx_.insert(self->rx_.end(), t->buffer, t->buffer + t->actual_length);
                break;
            case LIBUSB_TRANSFER_CANCELLED: break;
            case LIBUSB_TRANSFER_NO_DEVICE: self->gone_ = true; break;
            case LIBUSB_TRANSFER_STALL:
                if (self->failure_.empty()) self->failure_ = "EP1 IN stalled";
                break;
            case LIBUSB_TRANSFER_OVERFLOW:
                if (self->failure_.empty()) self->failure_ = "EP1 IN overflow (the board sent more than a packet)";
                break;
            default:
                if (self->failure_.empty()) self->failure_ = "EP1 IN transfer error";
                break;
        }
        const bool again = !self->stopping_ && !self->gone_ && self->failure_.empty() &&
                           (t->status == LIBUSB_TRANSFER_COMPLETED || t->status == LIBUSB_TRANSFER_TIMED_OUT);
        if (again) {
            const int r = libusb_submit_transfer(t);
            if (r == 0) {
                ++self->in_flight_;
            } else {
                self->note_failure_locked(r, "cannot queue an IN transfer again");
            }
        }
        self->cv_.notify_all();
    }

    void event_loop() {
        while (!quit_.load()) {
            timeval tv{0, 100 * 1000};
            const int r = libusb_handle_events_timeout_completed(ctx_, &tv, nullptr);
            if (r == 0 || r == LIBUSB_ERROR_INTERRUPTED || r == LIBUSB_ERROR_TIMEOUT) continue;
            std::lock_guard lock(m_);
            if (r == LIBUSB_ERROR_NO_DEVICE) {
                gone_ = true;
            } else if (failure_.empty()) {
                failure_ = "USB event handling failed (" + err_name(r) + ")";
            }
            events_dead_ = true;
            cv_.notify_all();
            return;
        }
    }

    libusb_context* ctx_;
    libusb_device_handle* h_;
    std::string address_;
    std::thread events_;
    std::atomic<bool> quit_{false};

    std::mutex m_;
    std::condition_variable cv_;
    std::deque<uint8_t> rx_;
    bool gone_ = false;
    bool stopping_ = false;
    bool events_dead_ = false;
    std::string failure_;
    int in_flight_ = 0;
    std::vector<libusb_transfer*> in_;
    std::vector<std::unique_ptr<unsigned char[]>> in_buf_;

    std::chrono::steady_clock::time_point last_probe_{};
};

struct Candidate {
    libusb_device_handle* handle = nullptr;
    std::string serial;
    std::string bus_port;
};

}  // namespace

std::unique_ptr<Transport> open_usb(const std::string& serial) {
    const std::string who = serial.empty() ? std::string("usb") : "usb:" + serial;
    Context context(who);
    std::vector<Candidate> opened;       // matching boards, opened
    std::vector<std::string> unopened;   // boards that could not be opened, and why
    std::vector<std::string> others;     // boards with another serial (when one was asked for)
    bool access_denied = false;
    {
        DeviceList devices(context.ctx, who);
        for (ssize_t i = 0; i < devices.count; ++i) {
            libusb_device* dev = devices.list[i];
            if (!is_board(dev)) continue;
            libusb_device_handle* h = nullptr;
            const int r = libusb_open(dev, &h);
            if (r != 0) {
                if (r == LIBUSB_ERROR_ACCESS) access_denied = true;
                unopened.push_back(bus_port_of(dev) + " (" + node_of(dev) + ": " + err_name(r) + ")");
                continue;
            }
            libusb_device_descriptor d{};
            libusb_get_device_descriptor(dev, &d);
            Candidate c{h, string_descriptor(h, d.iSerialNumber), bus_port_of(dev)};
            if (!serial.empty() && c.serial != serial) {
                libusb_close(h);
                others.push_back((c.serial.empty() ? std::string("(no serial)") : c.serial) + " at " + c.bus_port);
                continue;
            }
            opened.push_back(std::move(c));
        }
    }
    // Messages list boards in bus/port order, whatever libusb's order.
    std::sort(opened.begin(), opened.end(),
              [](const Candidate& a, const Candidate& b) { return a.bus_port < b.bus_port; });
    std::sort(unopened.begin(), unopened.end());
    std::sort(others.begin(), others.end());
    const auto join = [](const std::vector<std::string>& v) {
        std::string s;
        for (const std::string& x : v) s += (s.empty() ? "" : ", ") + x;
        return s;
    };
    const std::string board = "piezoloop USB board (" + vid_pid() + ")";
    const std::string not_opened = unopened.empty() ? std::string() : "; could not open " + join(unopened);
    if (opened.empty()) {
        if (access_denied)
            throw LinkError(who + ": access denied to the " + board + " at " + join(unopened) + "; " + kUdevHint);
        if (!serial.empty())
            throw LinkError(who + ": no " + board + " with serial number " + serial +
                            (others.empty() ? std::string() : "; attached: " + join(others)) + not_opened);
        throw LinkError(who + ": no " + board + " found" + not_opened);
    }
    if (opened.size() > 1 || (serial.empty() && !unopened.empty())) {
        std::vector<std::string> listed;
        for (const Candidate& c : opened)
            listed.push_back((c.serial.empty() ? std::string("(no serial)") : c.serial) + " at " + c.bus_port);
        for (Candidate& c : opened) libusb_close(c.handle);
        if (!serial.empty())  // the same serial twice: selection cannot work
            throw LinkError(who + ": " + std::to_string(listed.size()) + " " + board + "s report serial number " +
                            serial + " (" + join(listed) + "); serial numbers must be unique: attach one only");
        throw LinkError(who + ": " + std::to_string(opened.size() + unopened.size()) + " " + board + "s attached (" +
                        join(listed) + not_opened + "): choose one with --device usb:SERIAL");
    }
    Candidate chosen = opened.front();
    const std::string address = chosen.serial.empty() ? std::string("usb") : "usb:" + chosen.serial;
    const int r = libusb_claim_interface(chosen.handle, kInterface);
    if (r != 0) {
        libusb_close(chosen.handle);
        if (r == LIBUSB_ERROR_BUSY)
            throw LinkError(address + ": interface " + std::to_string(kInterface) +
                            " is claimed by another program (another piezoloop session?)");
        if (r == LIBUSB_ERROR_ACCESS) throw LinkError(address + ": access denied claiming the interface; " + kUdevHint);
        if (r == LIBUSB_ERROR_NO_DEVICE) throw LinkError(address + ": device unplugged");
        throw LinkError(address + ": cannot claim interface " + std::to_string(kInterface) + " (" + err_name(r) + ")");
    }
    return std::make_unique<UsbTransport>(context.release(), chosen.handle, address);
}

std::vector<UsbBoard> list_usb_boards() {
    Context context("usb");
    std::vector<UsbBoard> boards;
    DeviceList devices(context.ctx, "usb");
    for (ssize_t i = 0; i < devices.count; ++i) {
        libusb_device* dev = devices.list[i];
        if (!is_board(dev)) continue;
        UsbBoard b;
        b.vid = kVid;
        b.pid = kPid;
        b.bus_port = bus_port_of(dev);
        libusb_device_handle* h = nullptr;
        const int r = libusb_open(dev, &h);
        if (r == 0) {
            libusb_device_descriptor d{};
            libusb_get_device_descriptor(dev, &d);
            b.serial = string_descriptor(h, d.iSerialNumber);
            b.product = string_descriptor(h, d.iProduct);
            libusb_close(h);
        } else {
            b.product = "(cannot open " + node_of(dev) + ": " + err_name(r) +
                        (r == LIBUSB_ERROR_ACCESS ? std::string("; see docs/boards.md, \"USB access (udev)\")") : ")");
        }
        boards.push_back(std::move(b));
    }
    std::sort(boards.begin(), boards.end(), [](const UsbBoard& a, const UsbBoard& b) { return a.bus_port < b.bus_port; });
    return boards;
}

}  // namespace piezoloop::hostlink
