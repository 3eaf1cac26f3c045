// Smoke image: proves that the core headers build for this board's CPU, that
// the startup did its job (.data, static constructors, FPU access), and that
// the board computes exactly what the compiler computes at compile time.
//
// Every value is computed twice from the same code: at run time from inputs
// the compiler cannot see (laundered through volatile), and as a constant
// expression evaluated by the compiler. GCC folds IEEE float/double exactly
// (correctly rounded, round-to-nearest-even), so with -ffp-contract=off the
// two must agree bit for bit on the M7 FPU and on the M3's soft-float
// libgcc alike (docs/architecture.md, "Determinism"). Where an analytic value exists,
// the compile-time value is also pinned to it with static_assert.
//
// Output (UART), one line:
//   smoke board=<board> ok core=<float|q31> fpu=<dp|sp|none> <name>=<value>... checks=<n>
// or, when a check fails, one "smoke board=... check=<name> got=... want=..."
// line per failure and a last "smoke board=<board> FAIL failed=<k> of <n>";
// the exit status is the number of failed checks.
#include <bit>
#include <cstdint>

#include "app/core_sample.hpp"
#include "bsp/bsp.hpp"
#include "bsp/cortex-m/scb.hpp"
#include "bsp/text.hpp"
#include "piezoloop/q31.hpp"
#include "piezoloop/sample.hpp"

namespace {

using piezoloop::Q31;
using piezoloop::bsp::TextLine;

// The compiler must not constant-fold the run-time path.
template <class T>
T opaque(T value) {
    volatile T v = value;
    return v;
}

// ---- computations (each used at compile time and at run time) -------------

constexpr int32_t q31_mul(double a, double b) {
    return (Q31::from_double(a) * Q31::from_double(b)).raw();
}

// Three-tap FIR with block-exponent coefficients, as a biquad section will
// use them: quantise, multiply-accumulate in int64, one rounding shift.
constexpr int32_t q31_mac(const double (&c)[3], const double (&x)[3]) {
    const int e = piezoloop::block_exponent(c, 3);
    int64_t acc = 0;
    for (int i = 0; i < 3; ++i)
        acc += int64_t{piezoloop::quantize_mantissa(c[i], e)} * Q31::from_double(x[i]).raw();
    return piezoloop::q31_from_accumulator(acc, e).raw();
}

// First-order low-pass y += a (x - y), 32 steps of a unit step: a float
// recursion whose every rounding shows in the result bits.
constexpr float f32_lowpass(float a, float x) {
    float y = 0.0f;
    for (int i = 0; i < 32; ++i) y = y + a * (x - y);
    return y;
}

constexpr int32_t scale_to_q31(float full_scale, float physical) {
    return piezoloop::SignalScale{full_scale}.to_sample<Q31>(physical).raw();
}

constexpr float scale_roundtrip(float full_scale, float physical) {
    const piezoloop::SignalScale s{full_scale};
    return s.to_physical(s.to_sample<Q31>(physical));
}

constexpr double f64_div(double a, double b) { return a / b; }

// Compile-time values, pinned to analytic ones where they exist.
constexpr double kMacC[3] = {1.5, -0.75, 0.25};
constexpr double kMacX[3] = {0.5, 0.25, -0.125};
constexpr int32_t kWantMul = q31_mul(0.5, -0.25);
static_assert(kWantMul == -268435456, "0.5 * -0.25 = -0.125 = -2^28 in Q31");
constexpr int32_t kWantMac = q31_mac(kMacC, kMacX);
static_assert(kWantMac == 1140850688, "0.75 - 0.1875 - 0.03125 = 0.53125 = 17 * 2^26 in Q31");
constexpr float kWantLowpass = f32_lowpass(0.1f, 1.0f);
constexpr double kExactLowpass = [] {  // 1 - 0.9^32 in double
    double p = 1.0;
    for (int i = 0; i < 32; ++i) p *= 0.9;
    return 1.0 - p;
}();
static_assert(kWantLowpass - kExactLowpass < 1e-5 && kExactLowpass - kWantLowpass < 1e-5,
              "32 rounded float steps stay well within 1e-5 (~170 ulp near 1) of 1 - 0.9^32");
constexpr uint32_t kWantSqrt2 = std::bit_cast<uint32_t>(__builtin_sqrtf(2.0f));
static_assert(kWantSqrt2 == 0x3fb504f3u, "sqrt(2) correctly rounded to binary32");
constexpr int32_t kWantScale = scale_to_q31(40.0f, 10.0f);
static_assert(kWantScale == 536870912, "10 um of 40 um full scale = 0.25 = 2^29 in Q31");
constexpr float kWantRoundtrip = scale_roundtrip(40.0f, 10.0f);
static_assert(kWantRoundtrip == 10.0f, "0.25 is exact in Q31 and float");
constexpr uint64_t kWantThird = std::bit_cast<uint64_t>(f64_div(1.0, 3.0));
static_assert(kWantThird == 0x3fd5555555555555u, "1/3 correctly rounded to binary64");

// ---- start-up checks ------------------------------------------------------

// In .data (volatile, so the compiler cannot fold it to its initial value):
// only right if the startup copied .data from its load address (QEMU loads
// the ELF at load addresses, so RAM starts without it).
volatile int32_t g_data_word = 0x5A17C0DE;
// Dynamically initialised (its initialiser reads a volatile), so only set if
// the startup ran .init_array.
volatile int32_t g_ctor_source = 1234;
int32_t g_ctor_word = g_ctor_source + 1;

// ---- checking and reporting -------------------------------------------------

class Checks {
public:
    void expect(const char* name, int64_t got, int64_t want) {
        ++count_;
        if (got == want) return;
        ++failed_;
        TextLine line;
        line.str("smoke").key("board").str(piezoloop::bsp::kBoardName);
        line.key("check").str(name);
        line.key("got").dec(got).key("want").dec(want);
        line.flush();
    }
    void expect_bits(const char* name, float got, float want) {
        expect(name, std::bit_cast<uint32_t>(got), std::bit_cast<uint32_t>(want));
    }
    void expect_bits(const char* name, double got, double want) {
        expect(name, std::bit_cast<int64_t>(got), std::bit_cast<int64_t>(want));
    }
    int count() const { return count_; }
    int failed() const { return failed_; }

private:
    int count_ = 0;
    int failed_ = 0;
};

// What the FPU says it implements must cover what the image was built for:
// MVFR0 [7:4] single precision, [11:8] double precision (2 = supported),
// [3:0] number of 64-bit registers (1 = 16, 2 = 32).
const char* check_fpu(Checks& checks) {
#if defined(__ARM_FP)
    const uint32_t mvfr0 = piezoloop::bsp::scb::reg(piezoloop::bsp::scb::kMvfr0);
    checks.expect("fpu_sp", (mvfr0 >> 4) & 0xFu, 2);
    checks.expect("fpu_d16", (mvfr0 & 0xFu) >= 1u, 1);
#if (__ARM_FP & 8)
    checks.expect("fpu_dp", (mvfr0 >> 8) & 0xFu, 2);
    return "dp";
#else
    return "sp";
#endif
#else
    (void)checks;
    return "none";
#endif
}

}  // namespace

int app_main() {
    Checks checks;

    const int32_t mul = q31_mul(opaque(0.5), opaque(-0.25));
    checks.expect("q31_mul", mul, kWantMul);

    const double c[3] = {opaque(kMacC[0]), opaque(kMacC[1]), opaque(kMacC[2])};
    const double x[3] = {opaque(kMacX[0]), opaque(kMacX[1]), opaque(kMacX[2])};
    const int32_t mac = q31_mac(c, x);
    checks.expect("q31_mac", mac, kWantMac);

    // Saturation: the sign of the piezo command must never wrap.
    const Q31 max = Q31::max_value(), min = Q31::min_value();
    checks.expect("q31_sat_add", (max + Q31::from_raw(opaque(1))).raw(), Q31::kMaxRaw);
    checks.expect("q31_sat_sub", (min - Q31::from_raw(opaque(1))).raw(), Q31::kMinRaw);
    checks.expect("q31_sat_neg", (-Q31::from_raw(opaque(Q31::kMinRaw))).raw(), Q31::kMaxRaw);
    checks.expect("q31_sat_mul", (min * Q31::from_raw(opaque(Q31::kMinRaw))).raw(), Q31::kMaxRaw);

    const int32_t scale = scale_to_q31(opaque(40.0f), opaque(10.0f));
    checks.expect("scale_q31", scale, kWantScale);
    checks.expect_bits("scale_roundtrip", scale_roundtrip(opaque(40.0f), opaque(10.0f)),
                       kWantRoundtrip);

    const float lowpass = f32_lowpass(opaque(0.1f), opaque(1.0f));
    checks.expect_bits("f32_lowpass", lowpass, kWantLowpass);
    const float sqrt2 = __builtin_sqrtf(opaque(2.0f));
    checks.expect("f32_sqrt2", std::bit_cast<uint32_t>(sqrt2), kWantSqrt2);
    const double third = f64_div(opaque(1.0), opaque(3.0));
    checks.expect_bits("f64_third", third, std::bit_cast<double>(kWantThird));

    checks.expect("startup_data", g_data_word, 0x5A17C0DE);
    checks.expect("startup_ctor", opaque(g_ctor_word), 1235);
    const char* fpu = check_fpu(checks);

    TextLine line;
    line.str("smoke").key("board").str(piezoloop::bsp::kBoardName);
    if (checks.failed() != 0) {
        line.str(" FAIL").key("failed").dec(checks.failed()).str(" of ").dec(checks.count());
        line.flush();
        return checks.failed();
    }
    line.str(" ok");
    line.key("core").str(piezoloop::fw::kCoreSampleName);
    line.key("fpu").str(fpu);
    line.key("q31_mul").dec(mul);
    line.key("q31_mac").dec(mac);
    line.key("scale_q31").dec(scale);
    line.key("f32_lowpass").bits(lowpass);
    line.key("f32_sqrt2").bits(sqrt2);
    line.key("f64_third_hi").hex(static_cast<uint32_t>(std::bit_cast<uint64_t>(third) >> 32));
    line.key("checks").dec(checks.count());
    line.flush();
    return 0;
}
