# QEMU mps2-an385: the MPS2 FPGA image AN385 with a Cortex-M3.
# No FPU: soft-float ABI, and the control core runs in Q31 fixed point here
# (float work on this board is libgcc soft-float, for configuration only).
set(PIEZOLOOP_CPU_FLAGS -mcpu=cortex-m3 -mthumb -mfloat-abi=soft)
set(PIEZOLOOP_BSP_SOURCES ${PIEZOLOOP_FW_DIR}/bsp/mps2/board.cpp
                          ${PIEZOLOOP_FW_DIR}/bsp/mps2/semihosting_storage.cpp)
set(PIEZOLOOP_LINKER_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/memory.ld)
set(PIEZOLOOP_NUM_IRQ 32)        # AN385: 32 external interrupts
set(PIEZOLOOP_FW_SAMPLE q31)
set(PIEZOLOOP_QEMU_MACHINE mps2-an385)
