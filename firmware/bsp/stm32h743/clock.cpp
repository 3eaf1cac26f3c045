// Clock tree of the NUCLEO-H743ZI2 (STM32H743ZI, silicon revision V, the
// one that runs at 480 MHz), from RM0433 §6 (PWR), §8 (RCC), §4 (FLASH):
//
//   HSE 8 MHz, bypass: the ST-LINK's MCO drives PH0 (UM2407, default
//   solder bridges) -> /M1 = 4 -> 2 MHz (PLL1RGE 2..4 MHz, wide VCO)
//   -> x N1 = 480 -> VCO 960 MHz -> /P1 = 2 -> 480 MHz sys_ck (CPU)
//                                -> /Q1 = 20 -> 48 MHz USB kernel clock
//   D1CPRE /1: CPU 480 MHz; HPRE /2: AXI/AHB 240 MHz; D1PPRE, D2PPRE1,
//   D2PPRE2, D3PPRE /2: APB1..4 120 MHz; APB timers x2: 240 MHz.
//   ADC kernel clock: per_ck = HSI 64 MHz (left on), see board.cpp.
//
// Supply and voltage scaling: LDO supply (PWR_CR3: LDOEN, not bypass; the
// supply configuration is write-once after power-on); 480 MHz needs VOS0,
// which is VOS1 plus the overdrive (SYSCFG_PWRCR.ODEN), entered from VOS1
// after VOSRDY. Flash: 4 wait states and WRHIGHFREQ = 2 for a 240 MHz AXI
// clock in VOS0 (RM0433 Table 17), set before the switch.
//
// Returns false, leaving the CPU on HSI 64 MHz, if the HSE or the PLL does
// not become ready (e.g. MCO not connected): the firmware then refuses to
// run the loop rather than run it on an unexpected clock.
#include <cstdint>

#include "bsp/stm32h743/regs.hpp"

namespace piezoloop::bsp::stm32 {

namespace {

// Generous spin limits: each check is a few cycles at 64 MHz (HSI); HSE
// start-up is a few ms at worst (bypass: immediate).
constexpr uint32_t kSpin = 2'000'000;

bool wait_field(uintptr_t address, uint32_t mask, uint32_t value) {
    for (uint32_t i = 0; i < kSpin; ++i)
        if ((reg(address) & mask) == value) return true;
    return false;
}
bool wait_set(uintptr_t address, uint32_t mask) { return wait_field(address, mask, mask); }

}  // namespace

bool clock_init() {
    using namespace rcc;
    // 1. Supply: LDO on, bypass off; wait until the voltage levels are valid.
    modify(pwr::kCr3, pwr::kCr3Bypass | pwr::kCr3LdoEn, pwr::kCr3LdoEn);
    if (!wait_set(pwr::kCsr1, pwr::kCsr1ActVosRdy)) return false;

    // 2. VOS1, then VOS0 via the overdrive.
    modify(pwr::kD3cr, pwr::kD3crVosMask, pwr::kD3crVos1);
    if (!wait_set(pwr::kD3cr, pwr::kD3crVosRdy)) return false;
    reg(kApb4enr) = reg(kApb4enr) | kApb4SyscfgEn;
    if ((reg(kApb4enr) & kApb4SyscfgEn) == 0u) return false;  // read back: the enable has landed
    reg(syscfg::kPwrcr) = reg(syscfg::kPwrcr) | syscfg::kPwrcrOden;
    if (!wait_set(pwr::kD3cr, pwr::kD3crVosRdy)) return false;

    // 3. HSE in bypass (external clock on PH0).
    reg(kCr) = reg(kCr) | kCrHseByp;
    reg(kCr) = reg(kCr) | kCrHseOn;
    if (!wait_set(kCr, kCrHseRdy)) return false;

    // 4. PLL1: HSE / 4 = 2 MHz, x 480 = 960 MHz, P /2, Q /20, R /2.
    modify(kPllckselr, 3u | kDivm1Mask, kPllSrcHse | (4u << kDivm1Shift));
    modify(kPllcfgr, kPll1CfgMask, kPll1Rge2To4MHz | kDivp1En | kDivq1En | kDivr1En);
    reg(kPll1divr) = (480u - 1u) | ((2u - 1u) << 9) | ((20u - 1u) << 16) | ((2u - 1u) << 24);
    reg(kCr) = reg(kCr) | kCrPll1On;
    if (!wait_set(kCr, kCrPll1Rdy)) return false;

    // 5. Flash wait states for 240 MHz AXI in VOS0, before the switch.
    modify(flash::kAcr, flash::kLatencyMask | flash::kWrHighFreqMask, 4u | (2u << 4));
    if ((reg(flash::kAcr) & flash::kLatencyMask) != 4u) return false;

    // 6. Bus prescalers, then the switch to PLL1.
    reg(kD1cfgr) = kHpreDiv2 | kD1ppreDiv2;  // D1CPRE /1
    reg(kD2cfgr) = kD2ppre1Div2 | kD2ppre2Div2;
    reg(kD3cfgr) = kD3ppreDiv2;
    modify(kCfgr, kCfgrSwMask, kCfgrSwPll1);
    if (!wait_field(kCfgr, kCfgrSwsMask, kCfgrSwPll1 << kCfgrSwsShift)) return false;

    // 7. Kernel clocks: USB from PLL1Q (48 MHz), ADC from per_ck (= HSI).
    modify(kD2ccip2r, kUsbSelMask, kUsbSelPll1Q);
    modify(kD1ccipr, kCkperSelMask, 0u);
    modify(kD3ccipr, kAdcSelMask, kAdcSelPerCk);
    return true;
}

}  // namespace piezoloop::bsp::stm32
