// The tick's converters: see bsp/mps2/board_io.hpp.
#pragma once

#include "bsp/mps2/board_io.hpp"
