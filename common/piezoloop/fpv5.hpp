// PIEZOLOOP_FPV5: 1 when building for a Cortex-M7 whose FPU has double
// precision (FPv5: VMINNM/VMAXNM, VLDM/VSTM of the s registers) with GCC.
// The play operator's min/max (play.hpp) and the blocks that load and store
// through fixed FPU registers (pi_model.hpp, biquad.hpp) use it; every other
// target runs their plain C++, which is the same arithmetic.
#pragma once

#if defined(__ARM_ARCH_7EM__) && defined(__ARM_FP) && (__ARM_FP & 8) && defined(__GNUC__)
#define PIEZOLOOP_FPV5 1
#else
#define PIEZOLOOP_FPV5 0
#endif
