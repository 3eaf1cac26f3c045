// How fast a triangle over the whole range the commissioned loop follows
// within a tolerance (1 % of the range), read off the verification's
// whole-range triangles (1 Hz, 10 Hz, a tenth of the bandwidth): e_max
// grows about in proportion with the triangle's frequency (a triangle's
// turns leave an error of about its change of slope over the loop's
// bandwidth), so between two runs it is interpolated as a power law
// (straight on log-log axes). The error's floor (noise, the sensor's
// resolution) bends the curve upward on those axes, so the straight line
// lies above it and the frequency it gives errs low. Nothing is
// extrapolated: beyond the fastest run it is only "at least", below
// the slowest "less than".
#pragma once

#include <string>
#include <vector>

namespace piezoloop::commission {

struct TrackingPoint {
    double frequency_Hz = 0.0;
    double e_max_pct = 0.0;  // of the triangle's range
};

struct FastestTriangle {
    std::vector<TrackingPoint> runs;  // the runs it is read from, by frequency
    double tolerance_pct = 1.0;
    // The fastest triangle within the tolerance: interpolated between the
    // last run within it and the first beyond it; the fastest run when all
    // are within (at_least); 0 when even the slowest is beyond it.
    double up_to_Hz = 0.0;
    bool at_least = false;
};

// points: one per whole-range run, any order, frequencies > 0 and distinct,
// e_max finite and >= 0; tolerance_pct > 0. Throws std::invalid_argument
// naming the field otherwise (no points included).
FastestTriangle fastest_triangle(std::vector<TrackingPoint> points, double tolerance_pct = 1.0);

// One sentence for the log and the report, e.g. "triangles over the whole
// range within 1 % up to about 2.9 Hz (0.37 % at 1 Hz, 3.2 % at 10 Hz)".
std::string describe(const FastestTriangle& fastest);

}  // namespace piezoloop::commission
