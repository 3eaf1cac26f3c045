// The matrices of a board with two or three coupled axes (XY, XYZ stages).
//
// Input matrix: sensor readings -> axis positions, with per-axis offsets,
//   position_i = sum_j M[i][j] * reading_j + offset_um_i
// (a tilted sensor, two sensors on one axis). Output matrix: axis commands
// -> actuator channels, the static decoupling of the stage,
//   u_channel_i = sum_j M[i][j] * u_axis_j.
// Sensor j and channel j share axis j's converter full scales, so in Q31
// coefficient M[i][j] becomes the sample gain M[i][j] * fs_j / fs_i.
//
// Validation (configure time, main loop, double precision): every
// coefficient finite and |m| <= 16; every offset finite and |offset| <=
// 1000 µm (more than any piezo stage's travel); ||M||_1 >= 1/16; and the
// 1-norm condition number ||M||_1 ||M^-1||_1, computed in closed form (the
// adjugate over the determinant, n <= 3), at most 1000. Why 1000: the
// condition number bounds how much a relative error of the readings (or of
// the commands) is amplified by the map. A real stage's cross-coupling is a
// few tens of percent (condition below ~10); above 1000 two rows are nearly
// parallel (two sensors along almost the same direction), so 0.1 % of
// sensor noise becomes 100 % of a position, and a float's 24-bit resolution
// would lose 10 bits in the map: a configuration mistake, not a stage. The
// lower bound on ||M||_1 keeps a 1x1 "matrix" (always condition 1) from
// scaling a loop's signals to nothing; with it ||M^-1||_1 <= 16000.
//
// Application:
// - float: y_i = ((m_i0 x_0 + m_i1 x_1) + m_i2 x_2) + offset_i, in that
//   order, no fused multiply-add (the core's -ffp-contract=off). Each term
//   goes through at most n + 1 roundings, so the error is within
//   gamma_(n+1) (sum_j |m_ij x_j| + |offset_i|), gamma_k = k u / (1 - k u),
//   u = 2^-24 (Higham, Accuracy and Stability of Numerical Algorithms, 2nd
//   ed., ch. 3, inner products): about (n + 1) 2^-24 of the sum of the
//   terms' magnitudes.
// - Q31: Q31 cannot hold 1.0, so each row's sample gains (and its offset, a
//   gain on a constant one) use the core's block-exponent format (q31.hpp):
//   mantissa m = round(c 2^(31 - e)), value m 2^(e - 31), with e the
//   smallest exponent such that the row's sum of |c| (offset included) is
//   strictly below 2^e. Strictly: a row such as a permutation's (sum 1) then
//   takes e = 1 and holds its 1 exactly, where e = 0 would need the
//   mantissa 2^31. The row is accumulated in int64 (sum |m| < 2^31 + 2 and
//   |x| <= 2^31, plus the offset at 2^(62 - e): |acc| < 2^62 + 2^33, no
//   overflow), rounded half up to Q31 and saturated. Coefficient resolution
//   2^(e - 31) (2^-30 for a row whose gains sum to 1..2); the result is
//   within 2^(e - 1) sum_j |x_j| + 1/2 LSB of the exact product (x in full
//   scales; 2^e per term where a mantissa's rounding saturates at 2^31 - 1).
// An exact identity with zero offsets (and, in Q31, equal input and output
// scales) is bypassed: the outputs are the inputs, so a one-axis board, or
// any board with identity matrices, computes exactly what it would without
// them (and a NaN reading stays on its own axis instead of 0 * NaN reaching
// the others).
#pragma once

#include <array>
#include <cstdint>
#include <type_traits>

#include "piezoloop/det_math.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

inline constexpr int kMaxAxes = 3;
inline constexpr float kMaxAxisCoefficient = 16.0f;
inline constexpr double kMinAxisMatrixNorm1 = 1.0 / 16.0;
inline constexpr float kMaxAxisOffset_um = 1000.0f;
inline constexpr double kMaxAxisConditionNumber = 1000.0;
inline constexpr char kAxesGroup[] = "axes";

// n x n coefficients, m[i][j]: row i is output i, column j input j.
template <int N>
struct AxisMatrix {
    static_assert(N >= 1 && N <= kMaxAxes, "AxisMatrix<N>: 1 to 3 axes");
    std::array<std::array<float, N>, N> m{};

    static constexpr AxisMatrix identity() {
        AxisMatrix a{};
        for (int i = 0; i < N; ++i) a.m[i][i] = 1.0f;
        return a;
    }
    // Exactly the identity (-0 counts as 0).
    constexpr bool is_identity() const {
        for (int i = 0; i < N; ++i)
            for (int j = 0; j < N; ++j)
                if (!(m[i][j] == (i == j ? 1.0f : 0.0f))) return false;
        return true;
    }
    friend constexpr bool operator==(const AxisMatrix&, const AxisMatrix&) = default;
};

// Sensor readings -> axis positions: the gains and each axis's offset (µm).
template <int N>
struct InputMatrix {
    AxisMatrix<N> gain = AxisMatrix<N>::identity();
    std::array<float, N> offset_um{};
    friend constexpr bool operator==(const InputMatrix&, const InputMatrix&) = default;
};

namespace axes_detail {

// The fields as a user writes them (Status holds string literals).
inline constexpr const char* kInputMatrixField[kMaxAxes][kMaxAxes] = {
    {"input_matrix[0][0]", "input_matrix[0][1]", "input_matrix[0][2]"},
    {"input_matrix[1][0]", "input_matrix[1][1]", "input_matrix[1][2]"},
    {"input_matrix[2][0]", "input_matrix[2][1]", "input_matrix[2][2]"}};
inline constexpr const char* kOutputMatrixField[kMaxAxes][kMaxAxes] = {
    {"output_matrix[0][0]", "output_matrix[0][1]", "output_matrix[0][2]"},
    {"output_matrix[1][0]", "output_matrix[1][1]", "output_matrix[1][2]"},
    {"output_matrix[2][0]", "output_matrix[2][1]", "output_matrix[2][2]"}};
inline constexpr const char* kInputOffsetField[kMaxAxes] = {"input_offset_um[0]", "input_offset_um[1]",
                                                            "input_offset_um[2]"};
inline constexpr char kInputMatrixName[] = "input_matrix";
inline constexpr char kOutputMatrixName[] = "output_matrix";

constexpr double abs_d(double x) { return x < 0.0 ? -x : x; }

// Largest column sum of |a[i][j]|.
template <int N>
constexpr double norm1(const double (&a)[N][N]) {
    double best = 0.0;
    for (int j = 0; j < N; ++j) {
        double s = 0.0;
        for (int i = 0; i < N; ++i) s += abs_d(a[i][j]);
        if (s > best) best = s;
    }
    return best;
}

// adj(a) and det(a) = sum_j a[0][j] C_0j, so a^-1 = adj / det.
template <int N>
constexpr double adjugate(const double (&a)[N][N], double (&adj)[N][N]) {
    if constexpr (N == 1) {
        adj[0][0] = 1.0;
        return a[0][0];
    } else if constexpr (N == 2) {
        adj[0][0] = a[1][1];
        adj[0][1] = -a[0][1];
        adj[1][0] = -a[1][0];
        adj[1][1] = a[0][0];
        return a[0][0] * a[1][1] - a[0][1] * a[1][0];
    } else {
        // Cofactor C_ij from the rows and columns other than i and j, taken
        // cyclically, which folds the sign (-1)^(i+j) in.
        for (int i = 0; i < 3; ++i) {
            const int r1 = (i + 1) % 3, r2 = (i + 2) % 3;
            for (int j = 0; j < 3; ++j) {
                const int c1 = (j + 1) % 3, c2 = (j + 2) % 3;
                adj[j][i] = a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1];
            }
        }
        return a[0][0] * adj[0][0] + a[0][1] * adj[1][0] + a[0][2] * adj[2][0];
    }
}

template <int N>
constexpr void to_double(const AxisMatrix<N>& m, double (&a)[N][N]) {
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) a[i][j] = static_cast<double>(m.m[i][j]);
}

template <int N>
constexpr Status check_matrix(const AxisMatrix<N>& m, const char* name,
                              const char* const (&fields)[kMaxAxes][kMaxAxes]);

}  // namespace axes_detail

// ||M||_1 ||M^-1||_1 in double, closed form; +infinity when M is singular
// (a zero determinant). Configure-time only.
template <int N>
constexpr double condition_number_1(const AxisMatrix<N>& m) {
    double a[N][N]{}, adj[N][N]{};
    axes_detail::to_double(m, a);
    const double det = axes_detail::adjugate(a, adj);
    if (det == 0.0 || !is_finite(det)) return __builtin_huge_val();
    return axes_detail::norm1(a) * (axes_detail::norm1(adj) / axes_detail::abs_d(det));
}

namespace axes_detail {

template <int N>
constexpr Status check_matrix(const AxisMatrix<N>& m, const char* name,
                              const char* const (&fields)[kMaxAxes][kMaxAxes]) {
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) {
            const float c = m.m[i][j];
            if (!is_finite(c) || c > kMaxAxisCoefficient || c < -kMaxAxisCoefficient)
                return error(fields[i][j], "must be finite and within +-16");
        }
    double a[N][N]{};
    to_double(m, a);
    if (!(norm1(a) >= kMinAxisMatrixNorm1))
        return error(name, "too small: the largest column sum of |coefficients| must be >= 1/16");
    if (!(condition_number_1(m) <= kMaxAxisConditionNumber))
        return error(name, "singular or ill-conditioned (1-norm condition number above 1000)");
    return ok_status();
}

}  // namespace axes_detail

// The input matrix and its offsets; errors in group "axes".
template <int N>
constexpr Status validate_input_matrix(const InputMatrix<N>& in) {
    if (const Status s = axes_detail::check_matrix(in.gain, axes_detail::kInputMatrixName,
                                                   axes_detail::kInputMatrixField);
        !s.ok())
        return in_group(kAxesGroup, s);
    for (int i = 0; i < N; ++i) {
        const float o = in.offset_um[i];
        if (!is_finite(o) || o > kMaxAxisOffset_um || o < -kMaxAxisOffset_um)
            return in_group(kAxesGroup, error(axes_detail::kInputOffsetField[i],
                                              "must be finite and within +-1000 um"));
    }
    return ok_status();
}

// The output (decoupling) matrix; errors in group "axes".
template <int N>
constexpr Status validate_output_matrix(const AxisMatrix<N>& out) {
    return in_group(kAxesGroup, axes_detail::check_matrix(out, axes_detail::kOutputMatrixName,
                                                          axes_detail::kOutputMatrixField));
}

// A validated matrix in the form the tick applies, in sample units:
// y = M x + offset, or y = x when bypassed. Default: the bypass.
template <class T, int N>
class AxisTransform {
    static_assert(is_sample_type_v<T>, "AxisTransform<T>: T is float or Q31");
    static_assert(N >= 1 && N <= kMaxAxes, "AxisTransform<N>: 1 to 3 axes");
    static constexpr bool kFloat = std::is_same_v<T, float>;

public:
    constexpr AxisTransform() = default;

    // m and offset (physical, the outputs' unit) validated by the caller;
    // in / out: each input's and each output's scale. Fails (and changes
    // nothing) only in Q31, when a row's sample gains, with the scales'
    // ratios, sum to 2^30 or more; `name` names the matrix then.
    constexpr Status configure(const AxisMatrix<N>& m, const std::array<float, N>& offset,
                               const std::array<SignalScale, N>& in, const std::array<SignalScale, N>& out,
                               const char* name) {
        bool same_scales = true;
        bool zero_offsets = true;
        for (int i = 0; i < N; ++i) {
            same_scales = same_scales && in[i].full_scale == out[i].full_scale;
            zero_offsets = zero_offsets && offset[i] == 0.0f;
        }
        const bool bypass = m.is_identity() && zero_offsets && (kFloat || same_scales);
        if constexpr (kFloat) {
            coef_ = m.m;
            offset_ = offset;
        } else {
            Coef mant{};
            std::array<int64_t, N> off{};
            std::array<int, N> exps{};
            for (int i = 0; i < N; ++i) {
                double c[N + 1]{};
                double l1 = 0.0;
                for (int j = 0; j < N; ++j) {
                    c[j] = static_cast<double>(m.m[i][j]) * static_cast<double>(in[j].full_scale) /
                           static_cast<double>(out[i].full_scale);
                    l1 += axes_detail::abs_d(c[j]);
                }
                c[N] = static_cast<double>(offset[i]) / static_cast<double>(out[i].full_scale);
                l1 += axes_detail::abs_d(c[N]);
                if (!(l1 < 1073741824.0))  // 2^30
                    return error(name, "with the axes' full scales, a row's sample gains must sum below 2^30");
                int e = -31;
                double bound = 1.0 / 2147483648.0;  // 2^e
                while (!(l1 < bound)) {
                    bound *= 2.0;
                    ++e;
                }
                for (int j = 0; j < N; ++j) mant[i][j] = quantize_mantissa(c[j], e);
                // The offset at the accumulator's scale, 2^(62 - e) per unit:
                // |c[N]| < 2^e, so below 2^62.
                double scale = 1.0;
                for (int k = 0; k < 62 - e; ++k) scale *= 2.0;
                const double v = c[N] * scale;
                off[i] = static_cast<int64_t>(v >= 0.0 ? v + 0.5 : v - 0.5);
                exps[i] = e;
            }
            mant_ = mant;
            offset_acc_ = off;
            exp_ = exps;
        }
        bypass_ = bypass;
        return ok_status();
    }

    constexpr bool bypassed() const { return bypass_; }
    // Q31: row i's block exponent (its coefficients' resolution is 2^(e - 31)).
    constexpr int exponent(int row) const { return exp_[row]; }

    // y = M x + offset (x and y may not alias). Constant time.
    constexpr void apply(const std::array<T, N>& x, std::array<T, N>& y) const {
        if (bypass_) {
            y = x;
            return;
        }
        for (int i = 0; i < N; ++i) {
            if constexpr (kFloat) {
                float acc = coef_[i][0] * x[0];
                for (int j = 1; j < N; ++j) acc = acc + coef_[i][j] * x[j];
                y[i] = acc + offset_[i];
            } else {
                int64_t acc = offset_acc_[i];
                for (int j = 0; j < N; ++j) acc += int64_t{mant_[i][j]} * x[j].raw();
                y[i] = q31_from_accumulator(acc, exp_[i]);
            }
        }
    }

private:
    using Coef = std::array<std::array<int32_t, N>, N>;
    bool bypass_ = true;
    // float
    std::array<std::array<float, N>, N> coef_{};
    std::array<float, N> offset_{};
    // Q31
    Coef mant_{};
    std::array<int64_t, N> offset_acc_{};
    std::array<int, N> exp_{};
};

}  // namespace piezoloop
