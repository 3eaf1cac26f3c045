# NUCLEO-H743ZI2 (STM32H743ZI): Cortex-M7 with the double-precision FPU
# (FPv5-D16), hard-float ABI, float core. Builds and links only here; it
# cannot run in QEMU.
set(PIEZOLOOP_CPU_FLAGS -mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard)
set(PIEZOLOOP_BSP_SOURCES ${CMAKE_CURRENT_LIST_DIR}/board.cpp ${CMAKE_CURRENT_LIST_DIR}/clock.cpp
                          ${CMAKE_CURRENT_LIST_DIR}/usb_otg_fs.cpp ${CMAKE_CURRENT_LIST_DIR}/flash_storage.cpp)
set(PIEZOLOOP_LINKER_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/memory.ld)
set(PIEZOLOOP_NUM_IRQ 150)       # STM32H743 vector table: IRQ 0..149 (WAKEUP_PIN = 149)
set(PIEZOLOOP_FW_SAMPLE float)
# Converters for three axes (board_io.hpp): also build servo_xyz.elf.
set(PIEZOLOOP_XYZ_IMAGE ON)
