// The fields of a self-test case line that the board and the host replay
// both print, written by the same code so they can be compared as text.
#pragma once

#include "app/json_line.hpp"
#include "app/selftest_cases.hpp"

namespace piezoloop::fw {

// "frames","gaps","tracking_valid","e_max_um","e_rms_um","u_max_abs_V","log_hash"
template <class T>
void add_log_fields(JsonLine& j, const SelfTestCase& c, const LogAccumulator<T>& acc) {
    j.uint("frames", acc.frames()).uint("gaps", acc.gaps()).boolean("tracking_valid", c.tracking_valid);
    j.fixed("e_max_um", static_cast<double>(acc.e_max_um()), 4);
    j.fixed("e_rms_um", acc.e_rms_um(), 4);
    j.fixed("u_max_abs_V", static_cast<double>(acc.u_max_abs_V()), 4);
    j.hex64("log_hash", acc.log_hash());
}

}  // namespace piezoloop::fw
