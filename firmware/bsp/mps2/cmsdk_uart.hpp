// ARM CMSDK APB UART (Cortex-M System Design Kit TRM, ARM DDI 0479): the
// UARTs of the MPS2 FPGA images. A one-byte buffer each way, no FIFO.
// Registers (offsets from the base):
//   0x000 DATA      write: byte to send; read: byte received
//   0x004 STATE     bit 0 TX buffer full, bit 1 RX buffer full (+ overruns)
//   0x008 CTRL      bit 0 TX enable, bit 1 RX enable (+ interrupt enables)
//   0x00C INTSTATUS / INTCLEAR
//   0x010 BAUDDIV   PCLK / baud, at least 16
// QEMU models the same registers (hw/char/cmsdk-apb-uart.c); it drops bytes
// written while TX is disabled.
#pragma once

#include <cstdint>

namespace piezoloop::bsp::mps2 {

class CmsdkUart {
public:
    explicit constexpr CmsdkUart(uintptr_t base) : base_(base) {}

    void enable_tx(uint32_t pclk_Hz, uint32_t baud) const {
        reg(kBaudDiv) = pclk_Hz / baud;
        reg(kCtrl) = reg(kCtrl) | kCtrlTxEnable;
    }
    void enable_rx() const { reg(kCtrl) = reg(kCtrl) | kCtrlRxEnable; }
    // Non-blocking: true and the byte if one has arrived.
    bool try_get(char& c) const {
        if ((reg(kState) & kStateRxFull) == 0u) return false;
        c = static_cast<char>(reg(kData) & 0xFFu);
        return true;
    }
    void put(char c) const {
        while ((reg(kState) & kStateTxFull) != 0u) {
        }
        reg(kData) = static_cast<uint8_t>(c);
    }

private:
    static constexpr uintptr_t kData = 0x000;
    static constexpr uintptr_t kState = 0x004;
    static constexpr uintptr_t kCtrl = 0x008;
    static constexpr uintptr_t kBaudDiv = 0x010;
    static constexpr uint32_t kStateTxFull = 1u << 0;
    static constexpr uint32_t kStateRxFull = 1u << 1;
    static constexpr uint32_t kCtrlTxEnable = 1u << 0;
    static constexpr uint32_t kCtrlRxEnable = 1u << 1;

    volatile uint32_t& reg(uintptr_t offset) const {
        return *reinterpret_cast<volatile uint32_t*>(base_ + offset);
    }

    uintptr_t base_;
};

}  // namespace piezoloop::bsp::mps2
