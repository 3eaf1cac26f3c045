// A measured frequency response read back from the JSON `measure frf --out`
// writes (frf_report.hpp): the lines, the response, its per-line standard
// deviation and the loop rate. Read by `identify tf` and `analyze
// measured-loop`.
#pragma once

#include <string>
#include <vector>

#include "lti/lti.hpp"

namespace piezoloop::measure {

struct FrfData {
    std::vector<double> f_Hz;
    std::vector<design::cplx> response;  // u (V) -> y (um) at each line
    std::vector<double> std_db;          // per line, NaN where unknown; empty if the file has none
    double rate_Hz = 0.0;                // the loop rate the response was measured at
};

// Throws std::invalid_argument naming the file and the field (frequency_Hz,
// response[i], std_db, excitation.rate_Hz) that is missing or malformed.
FrfData load_frf_file(const std::string& path);

}  // namespace piezoloop::measure
