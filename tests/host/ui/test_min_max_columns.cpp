// The scope's min/max decimation (host/ui/min_max_columns) against a
// brute-force reference: for every column, every sample is visited and
// kept when it falls in the column. Exact equality: both pick the same floats.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ui/min_max_columns.hpp"

namespace piezoloop::ui {
namespace {

struct Reference {
    std::vector<float> first, second;
};

// For each column: the first sample (in time) that is the column's minimum,
// and the first that is its maximum, the earlier of the two first.
Reference brute_force(const std::vector<double>& t, const std::vector<float>& v, double t0, double span,
                      std::size_t columns) {
    Reference r;
    const float nan = std::nanf("");
    r.first.assign(columns, nan);
    r.second.assign(columns, nan);
    for (std::size_t c = 0; c < columns; ++c) {
        long lo = -1, hi = -1;
        for (std::size_t i = 0; i < t.size(); ++i) {
            if (std::floor((t[i] - t0) / span * static_cast<double>(columns)) != static_cast<double>(c)) continue;
            if (lo < 0 || v[i] < v[lo]) lo = static_cast<long>(i);
            if (hi < 0 || v[i] > v[hi]) hi = static_cast<long>(i);
        }
        if (lo < 0) continue;
        r.first[c] = v[std::min(lo, hi)];
        r.second[c] = v[std::max(lo, hi)];
    }
    return r;
}

void expect_same(const ColumnPoints& got, const Reference& want) {
    ASSERT_EQ(got.first.size(), want.first.size());
    for (std::size_t c = 0; c < want.first.size(); ++c) {
        if (std::isnan(want.first[c])) {
            EXPECT_TRUE(std::isnan(got.first[c]) && std::isnan(got.second[c])) << "column " << c;
            continue;
        }
        EXPECT_EQ(got.first[c], want.first[c]) << "column " << c;
        EXPECT_EQ(got.second[c], want.second[c]) << "column " << c;
    }
}

TEST(UiMinMaxColumns, EqualsBruteForceOnRandomRecords) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> value(-5.0f, 5.0f);
    for (int trial = 0; trial < 40; ++trial) {
        const double rate_Hz = 10000.0;
        const std::size_t n = 200 + rng() % 5000;
        const uint64_t first_tick = rng() % 100000;
        std::vector<double> t(n);
        std::vector<float> v(n);
        uint64_t tick = first_tick;
        for (std::size_t i = 0; i < n; ++i) {
            tick += 1 + (rng() % 20 == 0 ? rng() % 50 : 0);  // gaps now and then
            t[i] = static_cast<double>(tick) / rate_Hz;
            v[i] = rng() % 7 == 0 ? std::round(value(rng)) : value(rng);  // ties too
        }
        const std::size_t columns = 16 + rng() % 900;
        // Windows inside, overlapping either end and beyond the record.
        const double span = (t.back() - t.front()) * std::uniform_real_distribution<double>(0.1, 1.5)(rng);
        const double t0 = t.front() + (t.back() - t.front()) * std::uniform_real_distribution<double>(-0.3, 0.9)(rng);
        expect_same(min_max_columns(t, v, t0, span, columns), brute_force(t, v, t0, span, columns));
    }
}

TEST(UiMinMaxColumns, KeepsAOneSampleSpikeAndTheOrderInTime) {
    // Times in powers of two: 128 samples a column exactly.
    std::vector<double> t;
    std::vector<float> v;
    for (int i = 0; i < 1024; ++i) {
        t.push_back(i / 1024.0);
        v.push_back(i == 677 ? 9.0f : 0.001f * static_cast<float>(i));
    }
    const ColumnPoints p = min_max_columns(t, v, 0.0, 1.0, 8);
    EXPECT_EQ(p.first[5], 0.001f * 640.0f);  // the column's first sample, its minimum
    EXPECT_EQ(p.second[5], 9.0f);            // the spike, after it
    EXPECT_EQ(p.first[0], 0.0f);             // a rising ramp: min first, then max
    EXPECT_EQ(p.second[0], 0.001f * 127.0f);
}

TEST(UiMinMaxColumns, EmptyColumnsAreNaN) {
    const std::vector<double> t = {0.0, 0.05};
    const std::vector<float> v = {1.0f, 2.0f};
    const ColumnPoints p = min_max_columns(t, v, 0.0, 0.1, 4);
    EXPECT_EQ(p.first[0], 1.0f);
    EXPECT_TRUE(std::isnan(p.first[1]));
    EXPECT_EQ(p.first[2], 2.0f);
    EXPECT_TRUE(std::isnan(p.first[3]));
}

}  // namespace
}  // namespace piezoloop::ui
