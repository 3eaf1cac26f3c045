# QEMU mps2-an500: the MPS2 FPGA image AN500 with a Cortex-M7.
# QEMU's Cortex-M7 model reports MVFR0 = 0x10110221: FPv5 with double
# precision and 16 double registers, i.e. exactly -mfpu=fpv5-d16 (the smoke
# image checks MVFR0 at run time). Hard-float ABI: float arguments and
# results stay in s-registers, no core<->FPU moves per call.
set(PIEZOLOOP_CPU_FLAGS -mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard)
set(PIEZOLOOP_BSP_SOURCES ${PIEZOLOOP_FW_DIR}/bsp/mps2/board.cpp
                          ${PIEZOLOOP_FW_DIR}/bsp/mps2/semihosting_storage.cpp)
set(PIEZOLOOP_LINKER_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/memory.ld)
set(PIEZOLOOP_NUM_IRQ 32)        # QEMU gives the AN385/AN500 NVIC 32 lines
set(PIEZOLOOP_FW_SAMPLE float)
set(PIEZOLOOP_QEMU_MACHINE mps2-an500)
