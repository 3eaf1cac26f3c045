// Axis matrices: validation (named fields, the condition number against
// numpy's) and application in float and Q31 against exact products
// (tools/ref/axis_matrix_ref.py -> tests/golden/axis_matrix_ref.json).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include <nlohmann/json.hpp>

#include "piezoloop/axes/axis_matrix.hpp"
#include "test_support.hpp"

using namespace piezoloop;

namespace {

const nlohmann::json& golden() {
    static const nlohmann::json j = test::load_golden("axis_matrix_ref");
    return j;
}

template <int N>
AxisMatrix<N> matrix_from(const nlohmann::json& rows) {
    AxisMatrix<N> m{};
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) m.m[i][j] = rows[i][j].get<float>();
    return m;
}

template <int N>
std::array<float, N> floats_from(const nlohmann::json& a) {
    std::array<float, N> v{};
    for (int i = 0; i < N; ++i) v[i] = a[i].get<float>();
    return v;
}

// The golden file's cases with n == N.
template <int N>
void check_case(const nlohmann::json& c, int& float_checks, int& q31_checks) {
    SCOPED_TRACE(c["name"].get<std::string>());
    InputMatrix<N> in{matrix_from<N>(c["matrix"]), floats_from<N>(c["offset_um"])};
    const bool valid = c["valid"].get<bool>();
    const Status s_in = validate_input_matrix(in);
    const Status s_out = validate_output_matrix(in.gain);
    EXPECT_EQ(s_in.ok(), valid);
    EXPECT_EQ(s_out.ok(), valid);
    // numpy inverts through LU in double, we through the adjugate: both are
    // within about cond * 2^-53 (< 1e-12 here) of the exact value.
    const double cond = condition_number_1(in.gain);
    if (c["cond1"].is_null()) {
        EXPECT_TRUE(std::isinf(cond)) << cond;
    } else {
        EXPECT_NEAR(cond, c["cond1"].get<double>(), 1e-9 * c["cond1"].get<double>());
    }
    if (!valid) {
        EXPECT_STREQ(s_in.group, "axes");
        EXPECT_STREQ(s_out.group, "axes");
        return;
    }

    std::array<SignalScale, N> fs{};
    for (int i = 0; i < N; ++i) fs[i] = SignalScale{c["full_scale"][i].get<float>()};

    // Float: at most n + 1 roundings per term (products, then n additions),
    // so |y - exact| <= gamma_(n+1) (sum |m x| + |offset|), u = 2^-24
    // (Higham, ch. 3). The reference is exact to 2^-53.
    AxisTransform<float, N> tf;
    ASSERT_TRUE(tf.configure(in.gain, in.offset_um, fs, fs, "input_matrix").ok());
    EXPECT_EQ(tf.bypassed(), false);
    const double u = std::ldexp(1.0, -24);
    const double gamma = (N + 1) * u / (1.0 - (N + 1) * u);
    for (const auto& p : c["float_products"]) {
        const std::array<float, N> x = floats_from<N>(p["x"]);
        std::array<float, N> y{};
        tf.apply(x, y);
        for (int i = 0; i < N; ++i) {
            double mag = std::fabs(static_cast<double>(in.offset_um[i]));
            for (int j = 0; j < N; ++j) mag += std::fabs(static_cast<double>(in.gain.m[i][j]) * x[j]);
            const double ref = p["y"][i].get<double>();
            EXPECT_LE(std::fabs(static_cast<double>(y[i]) - ref), gamma * mag) << "row " << i;
            ++float_checks;
        }
    }

    // Q31: row i's exponent e is the smallest with sum |c| < 2^e (gains at
    // the scales' ratios, offset included). A coefficient is within one
    // resolution step 2^(e-31) of its value (half a step by rounding; a whole
    // one where the rounding saturates a mantissa), so the result is within
    // 2^(e-31) sum_j |raw_j| LSB of the exact product, plus 1 LSB for the final
    // rounding and the offset's quantisation (2^(e-32) LSB).
    AxisTransform<Q31, N> tq;
    ASSERT_TRUE(tq.configure(in.gain, in.offset_um, fs, fs, "input_matrix").ok());
    for (int i = 0; i < N; ++i) {
        double l1 = std::fabs(static_cast<double>(in.offset_um[i]) / fs[i].full_scale);
        for (int j = 0; j < N; ++j)
            l1 += std::fabs(static_cast<double>(in.gain.m[i][j]) * fs[j].full_scale / fs[i].full_scale);
        int e = -31;
        while (!(l1 < std::ldexp(1.0, e))) ++e;
        EXPECT_EQ(tq.exponent(i), e) << "row " << i;
    }
    for (const auto& p : c["q31_products"]) {
        std::array<Q31, N> x{};
        double sum_raw = 0.0;
        for (int j = 0; j < N; ++j) {
            x[j] = Q31::from_raw(p["x_raw"][j].get<int32_t>());
            sum_raw += std::fabs(static_cast<double>(x[j].raw()));
        }
        std::array<Q31, N> y{};
        tq.apply(x, y);
        for (int i = 0; i < N; ++i) {
            const double exact = p["y_fs"][i].get<double>() * 2147483648.0;
            const double ref = std::clamp(exact, -2147483648.0, 2147483647.0);
            const double tol = std::ldexp(1.0, tq.exponent(i) - 31) * sum_raw + 1.0;
            EXPECT_LE(std::fabs(static_cast<double>(y[i].raw()) - ref), tol) << "row " << i;
            ++q31_checks;
        }
    }
}

}  // namespace

TEST(AxisMatrix, GoldenConditionNumbersAndProducts) {
    int cases = 0, float_checks = 0, q31_checks = 0, refused = 0;
    for (const auto& c : golden()["cases"]) {
        switch (c["n"].get<int>()) {
            case 1: check_case<1>(c, float_checks, q31_checks); break;
            case 2: check_case<2>(c, float_checks, q31_checks); break;
            case 3: check_case<3>(c, float_checks, q31_checks); break;
            default: FAIL() << "n out of range";
        }
        refused += c["valid"].get<bool>() ? 0 : 1;
        ++cases;
    }
    EXPECT_GE(cases, 30);
    EXPECT_GE(refused, 8);
    EXPECT_GE(float_checks, 300);
    EXPECT_GE(q31_checks, 400);
}

TEST(AxisMatrix, TheBoundaryOfTheConditionNumber) {
    // diag(1, 1/c): ||M||_1 = 1, ||M^-1||_1 = c, exactly.
    AxisMatrix<2> m = AxisMatrix<2>::identity();
    m.m[1][1] = 1.0f / 1000.0f;
    EXPECT_NEAR(condition_number_1(m), 1000.0, 1e-4);
    m.m[1][1] = 1.0f / 999.0f;
    EXPECT_TRUE(validate_output_matrix(m).ok());
    m.m[1][1] = 1.0f / 1001.0f;
    EXPECT_FALSE(validate_output_matrix(m).ok());
    m.m[1][1] = 1.0e-4f;  // condition 1e4
    const Status s = validate_output_matrix(m);
    EXPECT_STREQ(s.group, "axes");
    EXPECT_STREQ(s.field, "output_matrix");
    EXPECT_STREQ(s.message, "singular or ill-conditioned (1-norm condition number above 1000)");
}

TEST(AxisMatrix, RefusalsNameTheField) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    {
        InputMatrix<3> in{};
        in.gain.m[1][2] = nan;
        const Status s = validate_input_matrix(in);
        EXPECT_STREQ(s.group, "axes");
        EXPECT_STREQ(s.field, "input_matrix[1][2]");
        EXPECT_STREQ(s.message, "must be finite and within +-16");
    }
    {
        AxisMatrix<3> m = AxisMatrix<3>::identity();
        m.m[2][0] = -inf;
        EXPECT_STREQ(validate_output_matrix(m).field, "output_matrix[2][0]");
        m.m[2][0] = 16.0f;  // the bound itself is allowed
        EXPECT_TRUE(validate_output_matrix(m).ok());
        m.m[2][0] = 16.000002f;
        EXPECT_STREQ(validate_output_matrix(m).field, "output_matrix[2][0]");
    }
    {
        InputMatrix<2> in{};
        in.offset_um[1] = nan;
        EXPECT_STREQ(validate_input_matrix(in).field, "input_offset_um[1]");
        in.offset_um[1] = 1000.0f;
        EXPECT_TRUE(validate_input_matrix(in).ok());
        in.offset_um[1] = -1000.1f;
        const Status s = validate_input_matrix(in);
        EXPECT_STREQ(s.field, "input_offset_um[1]");
        EXPECT_STREQ(s.message, "must be finite and within +-1000 um");
    }
    {
        InputMatrix<3> in{};
        in.gain.m[2] = in.gain.m[0];  // two equal rows: singular
        const Status s = validate_input_matrix(in);
        EXPECT_STREQ(s.field, "input_matrix");
        EXPECT_STREQ(s.message, "singular or ill-conditioned (1-norm condition number above 1000)");
    }
    {
        AxisMatrix<1> m{};
        m.m[0][0] = 0.0f;
        EXPECT_STREQ(validate_output_matrix(m).field, "output_matrix");
        m.m[0][0] = 0.05f;  // condition 1, but it scales the axis to almost nothing
        const Status s = validate_output_matrix(m);
        EXPECT_STREQ(s.field, "output_matrix");
        EXPECT_STREQ(s.message, "too small: the largest column sum of |coefficients| must be >= 1/16");
        m.m[0][0] = -0.0625f;
        EXPECT_TRUE(validate_output_matrix(m).ok());
    }
}

TEST(AxisMatrix, Q31RefusesRowsTheScalesMakeTooLarge) {
    AxisMatrix<2> m = AxisMatrix<2>::identity();
    m.m[0][1] = 16.0f;
    const std::array<SignalScale, 2> fs{SignalScale{1.0e-3f}, SignalScale{1.0e6f}};
    AxisTransform<Q31, 2> t;
    const Status s = t.configure(m, {}, fs, fs, "input_matrix");
    EXPECT_STREQ(s.field, "input_matrix");
    EXPECT_TRUE(t.bypassed());  // unchanged
    m.m[0][1] = 0.0f;
    // Identity with different in and out scales is a gain, not a bypass.
    const std::array<SignalScale, 2> out{SignalScale{2.0f}, SignalScale{1.0e6f}};
    ASSERT_TRUE(t.configure(m, {}, fs, out, "input_matrix").ok());
    EXPECT_FALSE(t.bypassed());
}

TEST(AxisMatrix, IdentityIsBypassedExactly) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    AxisTransform<float, 3> t;
    const std::array<SignalScale, 3> fs{};
    ASSERT_TRUE(t.configure(AxisMatrix<3>::identity(), {0.0f, -0.0f, 0.0f}, fs, fs, "input_matrix").ok());
    EXPECT_TRUE(t.bypassed());
    std::array<float, 3> y{};
    t.apply({-0.0f, nan, 3.0e38f}, y);
    EXPECT_TRUE(std::signbit(y[0]) && y[0] == 0.0f);
    EXPECT_TRUE(std::isnan(y[1]));
    EXPECT_EQ(y[2], 3.0e38f);
    // A non-zero offset is applied, and the NaN then reaches only rows with it.
    ASSERT_TRUE(t.configure(AxisMatrix<3>::identity(), {0.0f, 0.0f, 1.0f}, fs, fs, "input_matrix").ok());
    EXPECT_FALSE(t.bypassed());
    t.apply({1.0f, 2.0f, 3.0f}, y);
    EXPECT_EQ(y, (std::array<float, 3>{1.0f, 2.0f, 4.0f}));

    // Q31: a permutation holds its ones exactly (e = 1, mantissa 2^30).
    AxisMatrix<3> perm{};
    perm.m[0][1] = perm.m[1][2] = perm.m[2][0] = 1.0f;
    const std::array<SignalScale, 3> q{SignalScale{50.0f}, SignalScale{50.0f}, SignalScale{50.0f}};
    AxisTransform<Q31, 3> tq;
    ASSERT_TRUE(tq.configure(perm, {}, q, q, "input_matrix").ok());
    std::array<Q31, 3> yq{};
    const std::array<Q31, 3> xq{Q31::min_value(), Q31::max_value(), Q31::from_raw(-12345)};
    tq.apply(xq, yq);
    EXPECT_EQ(yq[0], xq[1]);
    EXPECT_EQ(yq[1], xq[2]);
    EXPECT_EQ(yq[2], xq[0]);
}
