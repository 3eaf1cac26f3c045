// The scope's decimation: the samples of a time window split into screen
// pixel columns, and each column kept as its minimum and maximum, in the
// order they occur. Drawn as a line through both points of every column,
// this shows every excursion of the signal however many samples fall in a
// column (a spike of one sample stays visible), in 2 values per column
// whatever the loop rate.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace piezoloop::ui {

struct ColumnPoints {
    // Per column: first and second point in time (the earlier of min and max
    // first); NaN in both for a column without samples.
    std::vector<float> first, second;
};

// Samples at times t_s (ascending) with values v, over the window
// [t0_s, t0_s + span_s) in `columns` equal columns; samples outside the
// window are ignored. Column k holds t in [t0 + k w, t0 + (k+1) w), w = span / columns.
ColumnPoints min_max_columns(std::span<const double> t_s, std::span<const float> v, double t0_s, double span_s,
                             std::size_t columns);

// Column of time t (may be out of [0, columns) for t outside the window).
long column_of(double t_s, double t0_s, double span_s, std::size_t columns);

}  // namespace piezoloop::ui
