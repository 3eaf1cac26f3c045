// The core's run-time error texts (common/piezoloop/params/text_buffer.hpp):
// numbers printed with five significant digits, checked against the values
// printf's %.5g gives for the same numbers (an independent formatter).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "piezoloop/params/text_buffer.hpp"

using piezoloop::params::TextBuffer;

namespace {

std::string text(double v) {
    TextBuffer<32> t;
    t.append_number(v);
    return t.c_str();
}

TEST(ParamsTextBuffer, WholeNumbersPrintAsIntegers) {
    EXPECT_EQ(text(0), "0");
    EXPECT_EQ(text(16), "16");
    EXPECT_EQ(text(-1000000), "-1000000");
    EXPECT_EQ(text(4294967295.0), "4294967295");
    EXPECT_EQ(text(-2147483648.0), "-2147483648");
}

TEST(ParamsTextBuffer, OtherNumbersAgreeWithPrintfToFiveDigits) {
    // Decimal and exponent forms differ from %g's choice, so compare values:
    // the printed text, read back, equals %.5g's value.
    for (double v : {0.5, 0.1, 1.0 / 3.0, 2.5e-3, 123.456, 98765.4321, 3.4028234663852886e38, 1e-30, 1e30, 1e15,
                     -7.25e-9, 6.02214076e23, 1e12, 0.0015, 999999.5}) {
        char ref[32];
        std::snprintf(ref, sizeof ref, "%.5g", v);
        const std::string t = text(v);
        EXPECT_EQ(std::strtod(t.c_str(), nullptr), std::strtod(ref, nullptr)) << v << ": " << t << " vs " << ref;
    }
    EXPECT_EQ(text(0.5), "0.5");
    EXPECT_EQ(text(3.4028234663852886e38), "3.4028e+38");
    EXPECT_EQ(text(1e-30), "1e-30");
    EXPECT_EQ(text(2.5e-3), "0.0025");
}

TEST(ParamsTextBuffer, CutsAtItsCapacity) {
    TextBuffer<8> t;
    t.append("sections[3].b0");
    EXPECT_EQ(std::string(t.c_str()), "section");
    t.truncate(3);
    EXPECT_EQ(std::string(t.c_str()), "sec");
}

}  // namespace
