// The sample as the command line gives it: KIND:key=value,... with
//   grating:pitch=2,height_nm=50,duty=0.5   (pitch in µm, (0, 1e4]; duty (0, 1))
//   step:x=0,height_nm=50                   (x in µm, |x| <= 1e6)
//   dots:pitch=2,radius=0.5,height_nm=20    (radius in (0, pitch / 2))
// Keys left out keep the defaults shown; height_nm in (0, 1e6]. Throws
// std::invalid_argument naming the kind or key and its allowed range.
#pragma once

#include <string>

#include "scan/sample_surface.hpp"

namespace piezoloop::scan {

SampleSurface parse_sample_spec(const std::string& spec);

}  // namespace piezoloop::scan
