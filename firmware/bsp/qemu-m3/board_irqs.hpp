// External interrupts this board's BSP handles (the rest go to the default
// handler, which reports them and exits). Included by startup.cpp.
#pragma once

#include "bsp/mps2/irqs.hpp"
