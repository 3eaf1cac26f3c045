#include "bsp/stm32h743/usb_otg_fs.hpp"

#include <cstring>

#include "bsp/cortex-m/nvic.hpp"
#include "bsp/stm32h743/regs.hpp"
#include "piezoloop/usb/control.hpp"

namespace piezoloop::bsp::stm32::usbfs {

namespace {

// ---- OTG2_FS registers (RM0433 §57.14), offsets from the core base --------
constexpr uintptr_t kOtg = 0x40080000;
constexpr uintptr_t kGotgctl = 0x000, kGahbcfg = 0x008, kGusbcfg = 0x00C, kGrstctl = 0x010, kGintsts = 0x014,
                    kGintmsk = 0x018, kGrxstsp = 0x020, kGrxfsiz = 0x024, kDieptxf0 = 0x028, kGccfg = 0x038,
                    kDieptxf1 = 0x104;
constexpr uintptr_t kDcfg = 0x800, kDctl = 0x804, kDiepmsk = 0x810, kDoepmsk = 0x814, kDaint = 0x818,
                    kDaintmsk = 0x81C, kPcgcctl = 0xE00;
constexpr uintptr_t diepctl(int n) { return 0x900 + 0x20 * static_cast<uintptr_t>(n); }
constexpr uintptr_t diepint(int n) { return 0x908 + 0x20 * static_cast<uintptr_t>(n); }
constexpr uintptr_t dieptsiz(int n) { return 0x910 + 0x20 * static_cast<uintptr_t>(n); }
constexpr uintptr_t doepctl(int n) { return 0xB00 + 0x20 * static_cast<uintptr_t>(n); }
constexpr uintptr_t doepint(int n) { return 0xB08 + 0x20 * static_cast<uintptr_t>(n); }
constexpr uintptr_t doeptsiz(int n) { return 0xB10 + 0x20 * static_cast<uintptr_t>(n); }
constexpr uintptr_t fifo(int n) { return 0x1000 + 0x1000 * static_cast<uintptr_t>(n); }

constexpr uint32_t kGotgctlBvaloen = 1u << 6, kGotgctlBvaloval = 1u << 7;
constexpr uint32_t kGahbcfgGintmsk = 1u << 0;
constexpr uint32_t kGusbcfgPhysel = 1u << 6, kGusbcfgTrdtMask = 0xFu << 10, kGusbcfgFdmod = 1u << 30;
constexpr uint32_t kGrstctlCsrst = 1u << 0, kGrstctlRxfflsh = 1u << 4, kGrstctlTxfflsh = 1u << 5,
                   kGrstctlTxfnumAll = 0x10u << 6, kGrstctlAhbidl = 1u << 31;
constexpr uint32_t kIntRxflvl = 1u << 4, kIntUsbsusp = 1u << 11, kIntUsbrst = 1u << 12, kIntEnumdne = 1u << 13,
                   kIntIepint = 1u << 18, kIntOepint = 1u << 19;
constexpr uint32_t kGccfgPwrdwn = 1u << 16, kGccfgVbden = 1u << 21;
constexpr uint32_t kDcfgDspdFs = 3u, kDcfgDadShift = 4, kDcfgDadMask = 0x7Fu << 4;
constexpr uint32_t kDctlSdis = 1u << 1, kDctlCginak = 1u << 8;
constexpr uint32_t kEpUsbaep = 1u << 15, kEpTypBulk = 2u << 18, kEpStall = 1u << 21, kEpCnak = 1u << 26,
                   kEpSnak = 1u << 27, kEpSd0pid = 1u << 28, kEpEpdis = 1u << 30, kEpEpena = 1u << 31;
constexpr uint32_t kEpIntXfrc = 1u << 0, kEpIntStup = 1u << 3;
constexpr uint32_t kPktcnt1 = 1u << 19, kStupcnt3 = 3u << 29;
// GRXSTSP packet status.
constexpr uint32_t kPktOutData = 2, kPktSetupData = 6;

volatile uint32_t& r(uintptr_t offset) { return reg(kOtg + offset); }

// ---- FIFO plan (32-bit words) ----------------------------------------------
constexpr uint32_t kRxFifoWords = 128;  // SETUPs + 2 max packets + status, with room
constexpr uint32_t kTx0Words = 16;      // EP0 IN: one 64-byte packet
constexpr uint32_t kTx1Words = 64;      // EP1 IN: four 64-byte packets

Ring g_rx, g_tx;

// ---- the chapter-9 logic's view of this controller -------------------------
struct Hw {
    void set_address(uint8_t a) { modify(kOtg + kDcfg, kDcfgDadMask, static_cast<uint32_t>(a) << kDcfgDadShift); }
    void configure_endpoints(bool on);
    void set_endpoint_stall(uint8_t ep, bool stall);
    bool endpoint_stalled(uint8_t ep) const {
        const int n = ep & 0x0F;
        return (r((ep & 0x80) ? diepctl(n) : doepctl(n)) & kEpStall) != 0u;
    }
    usb::ControlReply vendor_setup(const usb::SetupPacket&, uint8_t*, std::size_t) {
        return usb::ControlReply::stall();  // the link protocol runs on the bulk endpoints
    }
    void vendor_data_out(const usb::SetupPacket&, const uint8_t*, std::size_t) {}
};

Hw g_hw;
// The serial number is the board's unique ID, known at run time only:
// init() sets it before the soft connect ("" until then).
usb::ControlHandler<Hw> g_ctrl{g_hw, usb::DeviceIdentity{}, "piezoloop", "piezoloop servo (NUCLEO-H743ZI2)",
                               "", usb::AddressTiming::kAtSetup};

// EP0 transfer state.
uint8_t g_setup[8];
const uint8_t* g_in_data = nullptr;
uint16_t g_in_left = 0;
bool g_in_zlp = false;
bool g_in_active = false;
enum class Ep0 : uint8_t { kIdle, kDataIn, kDataOut, kStatusIn, kStatusOut } g_ep0 = Ep0::kIdle;
uint8_t g_out_buf[256];
uint16_t g_out_want = 0, g_out_got = 0;
bool g_configured = false;
bool g_ep1_out_armed = false;
bool g_ep1_in_busy = false;

void write_fifo(int ep, const uint8_t* data, uint32_t n) {
    volatile uint32_t& f = r(fifo(ep));
    for (uint32_t i = 0; i < n; i += 4) {
        uint32_t w = 0;
        for (uint32_t k = 0; k < 4 && i + k < n; ++k) w |= static_cast<uint32_t>(data[i + k]) << (8 * k);
        f = w;
    }
}
void read_fifo(uint8_t* out, uint32_t n) {
    volatile uint32_t& f = r(fifo(0));
    for (uint32_t i = 0; i < n; i += 4) {
        const uint32_t w = f;
        for (uint32_t k = 0; k < 4 && i + k < n; ++k) out[i + k] = static_cast<uint8_t>(w >> (8 * k));
    }
}
void discard_fifo(uint32_t n) {
    for (uint32_t i = 0; i < n; i += 4) (void)static_cast<uint32_t>(r(fifo(0)));
}

// EP0 OUT ready for SETUPs (and OUT data / status packets of up to 64 B).
void arm_ep0_out() {
    r(doeptsiz(0)) = kStupcnt3 | kPktcnt1 | 64u;
    r(doepctl(0)) = r(doepctl(0)) | kEpEpena | kEpCnak;
}

void ep0_send_next() {
    const uint16_t n = g_in_left > usb::kEp0MaxPacket ? usb::kEp0MaxPacket : g_in_left;
    r(dieptsiz(0)) = kPktcnt1 | n;
    r(diepctl(0)) = r(diepctl(0)) | kEpEpena | kEpCnak;
    write_fifo(0, g_in_data, n);
    g_in_data += n;
    g_in_left = static_cast<uint16_t>(g_in_left - n);
    g_in_active = true;
}

void ep0_stall() {
    r(diepctl(0)) = r(diepctl(0)) | kEpStall;
    r(doepctl(0)) = r(doepctl(0)) | kEpStall;
    g_ep0 = Ep0::kIdle;
}

void ep0_status_in() {
    g_ep0 = Ep0::kStatusIn;
    g_in_data = nullptr;
    g_in_left = 0;
    g_in_zlp = false;
    ep0_send_next();  // zero-length packet
}

void handle_setup() {
    const usb::SetupPacket s = usb::SetupPacket::parse(g_setup);
    const usb::ControlReply reply = g_ctrl.setup(s);
    switch (reply.kind) {
        case usb::ControlReply::Kind::kStall: ep0_stall(); break;
        case usb::ControlReply::Kind::kStatusIn: ep0_status_in(); break;
        case usb::ControlReply::Kind::kDataIn:
            g_ep0 = Ep0::kDataIn;
            g_in_data = reply.data;
            g_in_left = reply.length;
            g_in_zlp = reply.zero_length_packet;
            ep0_send_next();
            break;
        case usb::ControlReply::Kind::kDataOut:
            g_ep0 = Ep0::kDataOut;
            g_out_want = reply.length;
            g_out_got = 0;
            break;
    }
    arm_ep0_out();
}

void arm_ep1_out() {
    if (!g_configured || g_ep1_out_armed || g_rx.free_space() < usb::kBulkMaxPacket) return;
    r(doeptsiz(1)) = kPktcnt1 | usb::kBulkMaxPacket;
    r(doepctl(1)) = r(doepctl(1)) | kEpEpena | kEpCnak;
    g_ep1_out_armed = true;
}

void ep1_send_next() {
    if (!g_configured || g_ep1_in_busy) return;
    uint8_t packet[usb::kBulkMaxPacket];
    const std::size_t n = g_tx.read(packet, sizeof packet);
    if (n == 0) return;
    r(dieptsiz(1)) = kPktcnt1 | static_cast<uint32_t>(n);
    r(diepctl(1)) = r(diepctl(1)) | kEpEpena | kEpCnak;
    write_fifo(1, packet, static_cast<uint32_t>(n));
    g_ep1_in_busy = true;
}

void Hw::configure_endpoints(bool on) {
    if (on) {
        r(doepctl(1)) = kEpUsbaep | kEpTypBulk | kEpSd0pid | usb::kBulkMaxPacket;
        r(diepctl(1)) = kEpUsbaep | kEpTypBulk | kEpSd0pid | (1u << 22) /* TXFNUM 1 */ | usb::kBulkMaxPacket;
        r(kDaintmsk) = r(kDaintmsk) | (1u << 1) | (1u << 17);
        g_configured = true;
        g_ep1_out_armed = false;
        g_ep1_in_busy = false;
        arm_ep1_out();
    } else {
        g_configured = false;
        if (r(diepctl(1)) & kEpEpena) r(diepctl(1)) = r(diepctl(1)) | kEpEpdis | kEpSnak;
        if (r(doepctl(1)) & kEpEpena) r(doepctl(1)) = r(doepctl(1)) | kEpEpdis | kEpSnak;
        r(diepctl(1)) = r(diepctl(1)) & ~kEpUsbaep;
        r(doepctl(1)) = r(doepctl(1)) & ~kEpUsbaep;
        r(kDaintmsk) = r(kDaintmsk) & ~((1u << 1) | (1u << 17));
    }
}

void Hw::set_endpoint_stall(uint8_t ep, bool stall) {
    const int n = ep & 0x0F;
    const uintptr_t ctl = (ep & 0x80) ? diepctl(n) : doepctl(n);
    if (stall) {
        r(ctl) = r(ctl) | kEpStall;
    } else {
        // Clearing a halt resets the data toggle to DATA0 (§9.4.5).
        r(ctl) = (r(ctl) & ~kEpStall) | kEpSd0pid;
    }
}

void bus_reset() {
    g_ctrl.bus_reset();
    for (int n = 0; n < 2; ++n) {
        r(doepctl(n)) = r(doepctl(n)) | kEpSnak;
        r(doepint(n)) = 0xFFFFFFFFu;
        r(diepint(n)) = 0xFFFFFFFFu;
    }
    r(kDaintmsk) = (1u << 0) | (1u << 16);  // EP0 IN and OUT
    r(kDoepmsk) = kEpIntXfrc | kEpIntStup;
    r(kDiepmsk) = kEpIntXfrc;
    modify(kOtg + kDcfg, kDcfgDadMask, 0u);
    r(kGrstctl) = kGrstctlTxfflsh | kGrstctlTxfnumAll;
    while (r(kGrstctl) & kGrstctlTxfflsh) {
    }
    g_ep0 = Ep0::kIdle;
    g_configured = false;
    arm_ep0_out();
}

void receive() {
    const uint32_t st = r(kGrxstsp);
    const int ep = static_cast<int>(st & 0xFu);
    const uint32_t count = (st >> 4) & 0x7FFu;
    const uint32_t status = (st >> 17) & 0xFu;
    if (status == kPktSetupData && ep == 0) {
        read_fifo(g_setup, 8);
    } else if (status == kPktOutData && count > 0) {
        if (ep == 0 && g_ep0 == Ep0::kDataOut && g_out_got + count <= sizeof g_out_buf) {
            read_fifo(g_out_buf + g_out_got, count);
            g_out_got = static_cast<uint16_t>(g_out_got + count);
        } else if (ep == 1) {
            uint8_t packet[usb::kBulkMaxPacket];
            const uint32_t n = count > sizeof packet ? sizeof packet : count;
            read_fifo(packet, n);
            discard_fifo(count - n);
            g_rx.write(packet, n);  // fits: armed only with a packet's room
        } else {
            discard_fifo(count);
        }
    }
}

void out_endpoint_events() {
    const uint32_t daint = r(kDaint) >> 16;
    if (daint & 1u) {
        const uint32_t ev = r(doepint(0));
        r(doepint(0)) = ev;
        if (ev & kEpIntStup) {
            handle_setup();
        } else if (ev & kEpIntXfrc) {
            if (g_ep0 == Ep0::kDataOut && g_out_got >= g_out_want) {
                g_ctrl.data_out_done(g_out_buf, g_out_got);
                ep0_status_in();
            } else if (g_ep0 == Ep0::kStatusOut) {
                g_ctrl.status_stage_done();
                g_ep0 = Ep0::kIdle;
            }
            arm_ep0_out();
        }
    }
    if (daint & 2u) {
        const uint32_t ev = r(doepint(1));
        r(doepint(1)) = ev;
        if (ev & kEpIntXfrc) {
            g_ep1_out_armed = false;
            arm_ep1_out();
        }
    }
}

void in_endpoint_events() {
    const uint32_t daint = r(kDaint) & 0xFFFFu;
    if (daint & 1u) {
        const uint32_t ev = r(diepint(0));
        r(diepint(0)) = ev;
        if (ev & kEpIntXfrc) {
            g_in_active = false;
            if (g_ep0 == Ep0::kDataIn) {
                if (g_in_left > 0) {
                    ep0_send_next();
                } else if (g_in_zlp) {
                    g_in_zlp = false;
                    ep0_send_next();
                } else {
                    g_ep0 = Ep0::kStatusOut;  // the host's zero-length OUT ends it
                }
            } else if (g_ep0 == Ep0::kStatusIn) {
                g_ctrl.status_stage_done();
                g_ep0 = Ep0::kIdle;
            }
        }
    }
    if (daint & 2u) {
        const uint32_t ev = r(diepint(1));
        r(diepint(1)) = ev;
        if (ev & kEpIntXfrc) {
            g_ep1_in_busy = false;
            ep1_send_next();
        }
    }
}

}  // namespace

bool init(const char* serial) {
    using namespace rcc;
    g_ctrl.set_serial(serial);  // the host must only ever see this one
    reg(kAhb1enr) = reg(kAhb1enr) | kAhb1Usb2OtgFsEn;
    reg(kAhb4enr) = reg(kAhb4enr) | kAhb4GpioAEn;
    if ((reg(kAhb1enr) & kAhb1Usb2OtgFsEn) == 0u) return false;
    // USB PHY supply detector on (VDD33USB from the 3.3 V rail on the board).
    reg(pwr::kCr3) = reg(pwr::kCr3) | pwr::kCr3Usb33Den;
    for (uint32_t i = 0; i < 1'000'000 && (reg(pwr::kCr3) & pwr::kCr3Usb33Rdy) == 0u; ++i) {
    }
    gpio::alternate(gpio::kPortA, 11, 10);
    gpio::alternate(gpio::kPortA, 12, 10);
    gpio::speed_very_high(gpio::kPortA, 11);
    gpio::speed_very_high(gpio::kPortA, 12);

    // Core reset (wait for the AHB master to be idle first).
    uint32_t spin = 0;
    while ((r(kGrstctl) & kGrstctlAhbidl) == 0u)
        if (++spin > 1'000'000) return false;
    r(kGrstctl) = r(kGrstctl) | kGrstctlCsrst;
    spin = 0;
    while (r(kGrstctl) & kGrstctlCsrst)
        if (++spin > 1'000'000) return false;

    // Embedded FS PHY, forced device mode, turnaround 6 (AHB >= 32 MHz).
    r(kGusbcfg) = (r(kGusbcfg) & ~kGusbcfgTrdtMask) | kGusbcfgPhysel | kGusbcfgFdmod | (6u << 10);
    // >= 25 ms for the forced mode to settle (RM0433: FDMOD takes effect
    // after 25 ms): CYCCNT runs at 480 MHz by now.
    const uint32_t t0 = reg(0xE0001004);
    while (reg(0xE0001004) - t0 < 30u * 480'000u) {
    }
    // Transceiver on; no VBUS sensing (PA9 is not wired for it): B-session valid forced.
    r(kGccfg) = (r(kGccfg) & ~kGccfgVbden) | kGccfgPwrdwn;
    r(kGotgctl) = r(kGotgctl) | kGotgctlBvaloen | kGotgctlBvaloval;
    r(kPcgcctl) = 0;

    r(kDcfg) = (r(kDcfg) & ~3u) | kDcfgDspdFs;
    r(kGrxfsiz) = kRxFifoWords;
    r(kDieptxf0) = (kTx0Words << 16) | kRxFifoWords;
    r(kDieptxf1) = (kTx1Words << 16) | (kRxFifoWords + kTx0Words);
    r(kGrstctl) = kGrstctlTxfflsh | kGrstctlTxfnumAll;
    while (r(kGrstctl) & kGrstctlTxfflsh) {
    }
    r(kGrstctl) = kGrstctlRxfflsh;
    while (r(kGrstctl) & kGrstctlRxfflsh) {
    }

    r(kGintsts) = 0xFFFFFFFFu;
    r(kGintmsk) = kIntRxflvl | kIntUsbrst | kIntEnumdne | kIntIepint | kIntOepint | kIntUsbsusp;
    r(kGahbcfg) = r(kGahbcfg) | kGahbcfgGintmsk;
    // Below the control tick: USB never delays a tick.
    nvic::set_priority(kIrq, 0x80);
    nvic::clear_pending(kIrq);
    nvic::enable(kIrq);
    r(kDctl) = r(kDctl) & ~kDctlSdis;  // soft connect: the host sees the device
    return true;
}

std::size_t read(uint8_t* out, std::size_t n) {
    const std::size_t got = g_rx.read(out, n);
    if (got != 0) {
        nvic::disable(kIrq);
        arm_ep1_out();
        nvic::enable(kIrq);
    }
    return got;
}

std::size_t write(const uint8_t* data, std::size_t n) {
    if (!g_configured) return 0;
    const std::size_t put = g_tx.write(data, n);
    nvic::disable(kIrq);
    ep1_send_next();
    nvic::enable(kIrq);
    return put;
}

bool configured() { return g_configured; }

}  // namespace piezoloop::bsp::stm32::usbfs

extern "C" void piezoloop_usb_otg_fs_isr() noexcept {
    using namespace piezoloop::bsp::stm32::usbfs;
    const uint32_t pending = r(kGintsts) & r(kGintmsk);
    if (pending & kIntUsbrst) {
        r(kGintsts) = kIntUsbrst;
        bus_reset();
    }
    if (pending & kIntEnumdne) {
        r(kGintsts) = kIntEnumdne;
        // Full speed: EP0 max packet 64 (MPSIZ 0), clear the global IN NAK.
        r(diepctl(0)) = r(diepctl(0)) & ~3u;
        r(kDctl) = r(kDctl) | kDctlCginak;
    }
    if (pending & kIntUsbsusp) r(kGintsts) = kIntUsbsusp;
    while (r(kGintsts) & kIntRxflvl) receive();
    if (pending & kIntOepint) out_endpoint_events();
    if (pending & kIntIepint) in_endpoint_events();
}
