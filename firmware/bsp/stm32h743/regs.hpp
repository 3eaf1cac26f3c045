// STM32H743 registers used by this BSP, written from the reference manual
// RM0433 (rev 8): memory map (§2.3.2), PWR (§6.8), RCC (§8.7), FLASH (§4.9),
// SYSCFG (§12.3), GPIO (§11.4), TIM6/7 (§39.4), ADC (§25.6), DAC (§26.7),
// SPI (§50), USART (§48.8), OTG (§57.14), device electronic signature
// (unique ID); the Cortex-M7's cache maintenance registers from the ARMv7-M
// Architecture Reference Manual (the system control space's cache
// maintenance operations) and the Cortex-M7 TRM. No
// vendor header is used. Only what the
// firmware touches is named; offsets are from each peripheral's base.
//
// NOT VERIFIED ON HARDWARE HERE (no board, no emulator for this part).
#pragma once

#include <cstdint>

namespace piezoloop::bsp::stm32 {

inline volatile uint32_t& reg(uintptr_t address) { return *reinterpret_cast<volatile uint32_t*>(address); }

// Read-modify-write of a field: clear `mask`, set `value` (already shifted).
inline void modify(uintptr_t address, uint32_t mask, uint32_t value) {
    reg(address) = (reg(address) & ~mask) | value;
}

// ---- power, clocks, flash -------------------------------------------------
namespace pwr {
inline constexpr uintptr_t kBase = 0x58024800;
inline constexpr uintptr_t kCsr1 = kBase + 0x04;  // ACTVOSRDY bit 13
inline constexpr uintptr_t kCr3 = kBase + 0x0C;   // BYPASS 0, LDOEN 1, SCUEN 2, USB33DEN 24, USB33RDY 26
inline constexpr uintptr_t kD3cr = kBase + 0x18;  // VOS[15:14], VOSRDY 13
inline constexpr uint32_t kCsr1ActVosRdy = 1u << 13;
inline constexpr uint32_t kCr3Bypass = 1u << 0, kCr3LdoEn = 1u << 1, kCr3ScuEn = 1u << 2;
inline constexpr uint32_t kCr3Usb33Den = 1u << 24, kCr3Usb33Rdy = 1u << 26;
inline constexpr uint32_t kD3crVosMask = 3u << 14, kD3crVos1 = 3u << 14, kD3crVosRdy = 1u << 13;
}  // namespace pwr

namespace syscfg {
inline constexpr uintptr_t kBase = 0x58000400;
inline constexpr uintptr_t kPwrcr = kBase + 0x2C;  // ODEN bit 0: VOS0 (overdrive) on top of VOS1
inline constexpr uint32_t kPwrcrOden = 1u << 0;
}  // namespace syscfg

namespace rcc {
inline constexpr uintptr_t kBase = 0x58024400;
inline constexpr uintptr_t kCr = kBase + 0x00;
inline constexpr uintptr_t kCfgr = kBase + 0x10;
inline constexpr uintptr_t kD1cfgr = kBase + 0x18;
inline constexpr uintptr_t kD2cfgr = kBase + 0x1C;
inline constexpr uintptr_t kD3cfgr = kBase + 0x20;
inline constexpr uintptr_t kPllckselr = kBase + 0x28;
inline constexpr uintptr_t kPllcfgr = kBase + 0x2C;
inline constexpr uintptr_t kPll1divr = kBase + 0x30;
inline constexpr uintptr_t kD1ccipr = kBase + 0x4C;
inline constexpr uintptr_t kD2ccip2r = kBase + 0x54;
inline constexpr uintptr_t kD3ccipr = kBase + 0x58;
inline constexpr uintptr_t kAhb1enr = kBase + 0xD8;
inline constexpr uintptr_t kAhb4enr = kBase + 0xE0;
inline constexpr uintptr_t kApb1lenr = kBase + 0xE8;
inline constexpr uintptr_t kApb4enr = kBase + 0xF4;

inline constexpr uint32_t kCrHseOn = 1u << 16, kCrHseRdy = 1u << 17, kCrHseByp = 1u << 18;
inline constexpr uint32_t kCrPll1On = 1u << 24, kCrPll1Rdy = 1u << 25;
inline constexpr uint32_t kCfgrSwMask = 7u, kCfgrSwPll1 = 3u, kCfgrSwsShift = 3, kCfgrSwsMask = 7u << 3;
// PLLCKSELR: PLLSRC[1:0] (2 = HSE), DIVM1[9:4].
inline constexpr uint32_t kPllSrcHse = 2u;
inline constexpr uint32_t kDivm1Shift = 4, kDivm1Mask = 0x3Fu << 4;
// PLLCFGR: PLL1FRACEN 0, PLL1VCOSEL 1 (0 = wide VCO 192..960 MHz), PLL1RGE[3:2], DIVP1EN 16, DIVQ1EN 17, DIVR1EN 18.
inline constexpr uint32_t kPll1CfgMask = 0xFu | (7u << 16);
inline constexpr uint32_t kPll1Rge2To4MHz = 1u << 2;
inline constexpr uint32_t kDivp1En = 1u << 16, kDivq1En = 1u << 17, kDivr1En = 1u << 18;
// D1CFGR: HPRE[3:0] (8 = /2), D1PPRE[6:4] (4 = /2), D1CPRE[11:8] (0 = /1).
inline constexpr uint32_t kHpreDiv2 = 8u, kD1ppreDiv2 = 4u << 4;
// D2CFGR: D2PPRE1[6:4], D2PPRE2[10:8]; D3CFGR: D3PPRE[6:4] (4 = /2).
inline constexpr uint32_t kD2ppre1Div2 = 4u << 4, kD2ppre2Div2 = 4u << 8, kD3ppreDiv2 = 4u << 4;
// D2CCIP2R: USBSEL[21:20] (1 = pll1_q_ck), USART234578SEL[2:0] (0 = rcc_pclk1).
inline constexpr uint32_t kUsbSelMask = 3u << 20, kUsbSelPll1Q = 1u << 20;
// D3CCIPR: ADCSEL[17:16] (2 = per_ck); D1CCIPR: CKPERSEL[29:28] (0 = hsi_ker_ck).
inline constexpr uint32_t kAdcSelMask = 3u << 16, kAdcSelPerCk = 2u << 16;
inline constexpr uint32_t kCkperSelMask = 3u << 28;

inline constexpr uint32_t kAhb1Adc12En = 1u << 5, kAhb1Usb2OtgFsEn = 1u << 27;
inline constexpr uint32_t kAhb4GpioAEn = 1u << 0, kAhb4GpioBEn = 1u << 1, kAhb4GpioCEn = 1u << 2,
                          kAhb4GpioDEn = 1u << 3, kAhb4GpioEEn = 1u << 4, kAhb4GpioFEn = 1u << 5,
                          kAhb4Adc3En = 1u << 24;
inline constexpr uint32_t kApb1lTim6En = 1u << 4, kApb1lSpi3En = 1u << 15, kApb1lUsart3En = 1u << 18,
                          kApb1lDac12En = 1u << 29;
inline constexpr uint32_t kApb4SyscfgEn = 1u << 1;
}  // namespace rcc

namespace flash {
inline constexpr uintptr_t kAcr = 0x52002000;  // LATENCY[3:0], WRHIGHFREQ[5:4]
inline constexpr uint32_t kLatencyMask = 0xFu, kWrHighFreqMask = 3u << 4;
// Bank 2's registers (§4.9: each bank's set, bank 2 at +0x100 from bank 1's).
inline constexpr uintptr_t kKeyr2 = 0x52002000 + 0x104;
inline constexpr uintptr_t kCr2 = 0x52002000 + 0x10C;
inline constexpr uintptr_t kSr2 = 0x52002000 + 0x110;
inline constexpr uintptr_t kCcr2 = 0x52002000 + 0x114;  // write 1 to clear the SR2 flag of the same bit
// Unlock sequence of FLASH_KEYRx (§4.5.1).
inline constexpr uint32_t kKey1 = 0x45670123u, kKey2 = 0xCDEF89ABu;
// FLASH_CR2: LOCK 0, PG 1, SER 2, PSIZE[5:4], START 7, SNB[10:8].
inline constexpr uint32_t kCrLock = 1u << 0, kCrPg = 1u << 1, kCrSer = 1u << 2, kCrStart = 1u << 7;
inline constexpr uint32_t kCrPsizeX64 = 3u << 4;  // 64-bit parallelism (VOS0/1 at 2.7-3.6 V, §4.3.8)
inline constexpr uint32_t kCrSnbShift = 8, kCrSnbMask = 7u << 8;
// FLASH_SR2: BSY 0, WBNE 1, QW 2; EOP 16; errors WRPERR 17, PGSERR 18,
// STRBERR 19, INCERR 21, OPERR 22.
inline constexpr uint32_t kSrBsy = 1u << 0, kSrWbne = 1u << 1, kSrQw = 1u << 2, kSrEop = 1u << 16;
inline constexpr uint32_t kSrErrors = (1u << 17) | (1u << 18) | (1u << 19) | (1u << 21) | (1u << 22);
// Bank 2 at 0x08100000, eight 128 KiB sectors; flash words are 256 bits
// (§4.3.7: programmed 32 bytes at a time, one ECC per word).
inline constexpr uintptr_t kBank2 = 0x08100000;
inline constexpr uint32_t kSectorBytes = 128u * 1024u;
inline constexpr uint32_t kWordBytes = 32;
}  // namespace flash

// ---- GPIO -------------------------------------------------------------------
namespace gpio {
inline constexpr uintptr_t kPortA = 0x58020000;
inline constexpr uintptr_t kPortB = 0x58020400;
inline constexpr uintptr_t kPortC = 0x58020800;
inline constexpr uintptr_t kPortD = 0x58020C00;
inline constexpr uintptr_t kPortE = 0x58021000;
inline constexpr uintptr_t kPortF = 0x58021400;
inline constexpr uintptr_t kModer = 0x00, kOtyper = 0x04, kOspeedr = 0x08, kPupdr = 0x0C, kIdr = 0x10,
                           kOdr = 0x14, kBsrr = 0x18, kAfrl = 0x20, kAfrh = 0x24;
inline constexpr uint32_t kModeInput = 0, kModeOutput = 1, kModeAlternate = 2, kModeAnalog = 3;

inline void mode(uintptr_t port, int pin, uint32_t m) {
    modify(port + kModer, 3u << (2 * pin), m << (2 * pin));
}
inline void alternate(uintptr_t port, int pin, uint32_t af) {
    const uintptr_t r = port + (pin < 8 ? kAfrl : kAfrh);
    const int shift = 4 * (pin & 7);
    modify(r, 0xFu << shift, af << shift);
    mode(port, pin, kModeAlternate);
}
inline void speed_very_high(uintptr_t port, int pin) { modify(port + kOspeedr, 3u << (2 * pin), 3u << (2 * pin)); }
inline void set(uintptr_t port, int pin, bool on) { reg(port + kBsrr) = on ? (1u << pin) : (1u << (pin + 16)); }
}  // namespace gpio

// ---- TIM6 (basic timer): the tick and the ADC trigger ------------------------
namespace tim6 {
inline constexpr uintptr_t kBase = 0x40001000;
inline constexpr uintptr_t kCr1 = kBase + 0x00, kCr2 = kBase + 0x04, kDier = kBase + 0x0C, kSr = kBase + 0x10,
                           kEgr = kBase + 0x14, kCnt = kBase + 0x24, kPsc = kBase + 0x28, kArr = kBase + 0x2C;
inline constexpr uint32_t kCr1Cen = 1u << 0, kCr1Urs = 1u << 2, kCr1Arpe = 1u << 7;
inline constexpr uint32_t kCr2MmsUpdate = 2u << 4;  // TRGO = update event
inline constexpr uint32_t kDierUie = 1u << 0, kSrUif = 1u << 0, kEgrUg = 1u << 0;
}  // namespace tim6

// ---- ADC1, ADC2, ADC3 (16-bit) ------------------------------------------------
namespace adc {
inline constexpr uintptr_t kAdc1 = 0x40022000;
inline constexpr uintptr_t kAdc2 = 0x40022100;
inline constexpr uintptr_t kCommon12 = 0x40022300;  // ADC1 and ADC2's common registers
inline constexpr uintptr_t kAdc3 = 0x58026000;      // D3 domain, its own common registers
inline constexpr uintptr_t kCommon3 = 0x58026300;
inline constexpr uintptr_t kIsr = 0x00, kIer = 0x04, kCr = 0x08, kCfgr = 0x0C, kCfgr2 = 0x10, kSmpr1 = 0x14,
                           kSmpr2 = 0x18, kPcsel = 0x1C, kSqr1 = 0x30, kDr = 0x40;
inline constexpr uintptr_t kCcr = 0x08;  // common: CKMODE[17:16], PRESC[21:18]
inline constexpr uint32_t kIsrAdrdy = 1u << 0, kIsrEoc = 1u << 2, kIsrOvr = 1u << 4;
inline constexpr uint32_t kIerEocie = 1u << 2;
inline constexpr uint32_t kCrAden = 1u << 0, kCrAddis = 1u << 1, kCrAdstart = 1u << 2, kCrBoostMask = 3u << 8,
                          kCrBoost25To50MHz = 3u << 8, kCrAdcallin = 1u << 16, kCrAdvregen = 1u << 28,
                          kCrDeeppwd = 1u << 29, kCrAdcal = 1u << 31;
// CFGR: RES[4:2] (0 = 16 bit), EXTSEL[9:5], EXTEN[11:10] (1 = rising), OVRMOD 12.
inline constexpr uint32_t kCfgrExtselShift = 5, kCfgrExtenRising = 1u << 10, kCfgrOvrmod = 1u << 12;
// adc_ext_trg13 = tim6_trgo: the one trigger table of ADC1, ADC2 and ADC3
// on the STM32H742/743/750/753 (RM0433, the ADC chapter's table of external
// triggers for regular channels).
inline constexpr uint32_t kExtselTim6Trgo = 13;
inline constexpr uint32_t kCcrPrescDiv2 = 1u << 18;
}  // namespace adc

// ---- DAC1 (12-bit, two channels) ---------------------------------------------
namespace dac {
inline constexpr uintptr_t kBase = 0x40007400;
inline constexpr uintptr_t kCr = kBase + 0x00, kDhr12r1 = kBase + 0x08, kDhr12r2 = kBase + 0x14,
                           kMcr = kBase + 0x3C;
inline constexpr uint32_t kCrEn1 = 1u << 0, kCrEn2 = 1u << 16;
}  // namespace dac

// ---- SPI3: the external DAC of a third axis ------------------------------------
namespace spi3 {
inline constexpr uintptr_t kBase = 0x40003C00;
inline constexpr uintptr_t kCr1 = kBase + 0x00, kCr2 = kBase + 0x04, kCfg1 = kBase + 0x08, kCfg2 = kBase + 0x0C,
                           kSr = kBase + 0x14, kIfcr = kBase + 0x18, kTxdr = kBase + 0x20;
// CR1: SPE 0, CSTART 9, SSI 12. CR2: TSIZE[15:0] (0: no fixed size).
inline constexpr uint32_t kCr1Spe = 1u << 0, kCr1Cstart = 1u << 9, kCr1Ssi = 1u << 12;
// CFG1: DSIZE[4:0] (bits per frame - 1), MBR[30:28] (0 = kernel clock / 2).
inline constexpr uint32_t kCfg1Dsize16 = 15u;
// CFG2: COMM[18:17] (1 = simplex transmitter), MASTER 22, CPHA 24, CPOL 25
// (both 0: mode 0), SSM 26 (slave select from SSI), AFCNTR 31 (the pins
// keep their alternate function while SPE is 0).
inline constexpr uint32_t kCfg2CommTx = 1u << 17, kCfg2Master = 1u << 22, kCfg2Ssm = 1u << 26,
                          kCfg2Afcntr = 1u << 31;
// SR: TXP 1 (room for a frame), TXC 12 (everything queued has been shifted out).
inline constexpr uint32_t kSrTxp = 1u << 1, kSrTxc = 1u << 12;
}  // namespace spi3

// ---- USART3 (ST-LINK virtual COM port) -------------------------------------
namespace usart3 {
inline constexpr uintptr_t kBase = 0x40004800;
inline constexpr uintptr_t kCr1 = kBase + 0x00, kBrr = kBase + 0x0C, kIsr = kBase + 0x1C, kRdr = kBase + 0x24,
                           kTdr = kBase + 0x28;
inline constexpr uint32_t kCr1Ue = 1u << 0, kCr1Re = 1u << 2, kCr1Te = 1u << 3;
inline constexpr uint32_t kIsrRxne = 1u << 5, kIsrTc = 1u << 6, kIsrTxe = 1u << 7;
}  // namespace usart3

// ---- device electronic signature: the 96-bit unique device ID ---------------
// RM0433, "Device electronic signature", unique device ID register (96 bits):
// three read-only, factory-programmed words in system memory; the same
// base address in the STM32H742/743/750/753 manual (RM0433) and the
// H745/747 one (RM0399). UID[31:0] = X and Y coordinates on the wafer,
// UID[39:32] = wafer number, UID[95:40] = lot number (ASCII). Never
// altered, unique per device: the board's serial number (USB and link).
namespace uid {
inline constexpr uintptr_t kBase = 0x1FF1E800;
inline constexpr uintptr_t kW0 = kBase + 0x00;  // UID[31:0]
inline constexpr uintptr_t kW1 = kBase + 0x04;  // UID[63:32]
inline constexpr uintptr_t kW2 = kBase + 0x08;  // UID[95:64]
}  // namespace uid

// ---- Cortex-M7 core: DWT cycle counter, caches ------------------------------
namespace core {
inline constexpr uintptr_t kDemcr = 0xE000EDFC;  // TRCENA bit 24
inline constexpr uintptr_t kDwtCtrl = 0xE0001000, kDwtCyccnt = 0xE0001004, kDwtLar = 0xE0001FB0;
inline constexpr uintptr_t kScbCcr = 0xE000ED14;      // IC bit 17, DC bit 16
inline constexpr uintptr_t kScbIciallu = 0xE000EF50;  // invalidate all I-cache
inline constexpr uintptr_t kScbDcimvac = 0xE000EF5C;  // invalidate the D-cache line holding an address
inline constexpr uintptr_t kScbDcisw = 0xE000EF60;    // invalidate a D-cache line by set and way
inline constexpr uintptr_t kScbCcsidr = 0xE000ED80;   // geometry of the cache CSSELR selects
inline constexpr uintptr_t kScbCsselr = 0xE000ED84;   // 0: the level-1 data cache
inline constexpr uint32_t kCcrDc = 1u << 16;
}  // namespace core

}  // namespace piezoloop::bsp::stm32
