// The whole simulated signal chain around a piezo stage, docs/models.md, 'Stages and scenarios': what a
// controller's DAC output goes through before its ADC reads it back.
//
//   u (V) -> DAC (bits, range) -> amplifier (input clamp, gain, first-order
//   bandwidth, output clamp) -> Hammerstein stage (hysteresis, dynamics)
//   -> sensor (gain, first-order bandwidth, offset, gain error, mains
//   pickup, seeded noise) -> ADC (bits, range) -> y
//
// The hysteresis may creep and the displacement drift (plant.hpp). The
// sensor's offset and mains pickup are in µm of displacement and read
// through the sensor's actual gain G = gain (1 + gain_error):
//   reading = lag(G x) + G (offset_um + mains_um(t)) + noise
// (after the sensor's bandwidth: they arise in its electronics).
//
// Every part is optional (bits 0 = ideal converter, bandwidth 0 = none).
// Float, libm-free and seeded, so the host simulator and the emulated boards
// produce the same bits (docs/architecture.md, "Determinism"). The loop's one tick of
// compute delay belongs to whoever runs the loop: the command computed at
// tick k is applied at tick k + 1.
#pragma once

#include <cstdint>

#include "piezoloop/det_math.hpp"
#include "piezoloop/mains_pickup.hpp"
#include "piezoloop/plant.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

struct ConverterConfig {
    int bits = 0;          // 0: ideal (no quantisation); else 2..24
    float min = -1e9f;     // input range in physical units; clamped to it
    float max = 1e9f;
    bool operator==(const ConverterConfig&) const = default;
};

struct AmplifierConfig {
    float gain = 1.0f;            // V/V
    float input_min_V = -1e9f, input_max_V = 1e9f;
    float output_min_V = -1e9f, output_max_V = 1e9f;
    float bandwidth_Hz = 0.0f;    // first-order, 0: none
};

struct SensorConfig {
    float gain = 1.0f;            // sensor units per µm (1: reads µm)
    float bandwidth_Hz = 0.0f;    // first-order, 0: none
    float noise_rms = 0.0f;       // in sensor units, added before the ADC
    uint32_t seed = 1;            // noise generator seed (non-zero)
    float offset_um = 0.0f;       // reading's offset, in µm of displacement
    float gain_error = 0.0f;      // relative: 0.02 reads 2 % more (gain * 1.02)
    MainsConfig mains{};          // pickup on the reading, in µm (off: count 0)
};

struct StageConfig {
    float rate_Hz = 100000.0f;
    ConverterConfig dac{};        // in V (controller output)
    AmplifierConfig amplifier{};
    PlantConfig plant{};          // piezo voltage (V) -> displacement (µm)
    SensorConfig sensor{};
    ConverterConfig adc{};        // in sensor units
};

// Quantiser of an ideal converter: clamp to [min, max] and round to the
// nearest of 2^bits levels spanning the range.
class Converter {
public:
    Status configure(const ConverterConfig& c) {
        if (c.bits != 0 && (c.bits < 2 || c.bits > 24)) return error("bits", "must be 0 (ideal) or in [2, 24]");
        if (!is_finite(c.min) || !is_finite(c.max) || !(c.min < c.max))
            return error("max", "range must be finite with min < max");
        config_ = c;
        max_code_ = c.bits == 0 ? 0u : (1u << c.bits) - 1u;
        lsb_ = c.bits == 0 ? 0.0f : (c.max - c.min) / static_cast<float>(max_code_);
        // Codes per unit, so the per-sample conversion multiplies instead of
        // dividing (a float division is ~4x the latency of a multiply and sits
        // in the simulated loop's dependency chain twice per tick). It can
        // round a value within an ulp of a half-code boundary to the other
        // code; that is still a nearest-code quantiser to within 1e-7 LSB, and
        // the same on every platform (one correctly rounded float division
        // here, IEEE multiply below, no contraction).
        inv_lsb_ = c.bits == 0 ? 0.0f : static_cast<float>(max_code_) / (c.max - c.min);
        max_code_f_ = static_cast<float>(max_code_);  // exact: max_code < 2^24
        return ok_status();
    }
    float apply(float x) const {
        if (!(x == x)) x = config_.min;  // NaN reads as the lowest code, like a railed input
        const float v = x < config_.min ? config_.min : (x > config_.max ? config_.max : x);
        if (config_.bits == 0) return v;
        const float t = (v - config_.min) * inv_lsb_;  // in codes, >= 0
        float code;
        if (config_.bits <= 22) {
            // Round to the nearest code (ties to even) in the float adder
            // itself: t + 1.5 * 2^23 has no fraction bits left for
            // 0 <= t < 2^22. No float -> int -> float round trip, whose
            // conversions are the slowest part of the simulated loop's
            // dependency chain.
            code = (t + kRoundingBias) - kRoundingBias;
            // v <= max, and the three roundings of t (v - min, inv_lsb_, the
            // product) put it at most max_code * 3 * 2^-24 above max_code:
            // < 0.4 up to 21 bits, so only 22 bits can round past it.
            if (config_.bits == 22 && code > max_code_f_) code = max_code_f_;
        } else {
            code = static_cast<float>(static_cast<uint32_t>(t + 0.5f));  // round half up
            if (code > max_code_f_) code = max_code_f_;
        }
        return config_.min + code * lsb_;
    }
    float lsb() const { return lsb_; }

private:
    ConverterConfig config_{};
    uint32_t max_code_ = 0;
    float lsb_ = 0.0f;
    float inv_lsb_ = 0.0f;  // 1 / lsb_ as max_code / (max - min)
    float max_code_f_ = 0.0f;
    static constexpr float kRoundingBias = 12582912.0f;  // 1.5 * 2^23
};

// First-order low-pass discretised by Tustin (closed form, no libm); a
// bandwidth of 0 passes the input through.
class FirstOrderLag {
public:
    Status configure(float bandwidth_Hz, float rate_Hz) {
        if (!is_finite(bandwidth_Hz) || bandwidth_Hz < 0.0f || !(bandwidth_Hz < 0.5f * rate_Hz))
            return error("bandwidth_Hz", "must be 0 (none) or in (0, rate / 2)");
        if (bandwidth_Hz == 0.0f) {
            enabled_ = false;
            return ok_status();
        }
        const double w = 2.0 * 3.14159265358979323846 * bandwidth_Hz;
        const double k = 2.0 * static_cast<double>(rate_Hz);
        b_ = static_cast<float>(w / (k + w));          // b0 = b1
        a_ = static_cast<float>((w - k) / (k + w));    // y = b x + b x1 - a y1
        enabled_ = true;
        return ok_status();
    }
    void reset(float x0 = 0.0f) { x1_ = y1_ = x0; }
    float apply(float x) {
        if (!enabled_) return x;
        // b x + (b x1 - a y1): the part from the previous sample does not
        // wait for x, so only one multiply and one add are on the simulated
        // loop's dependency chain (b (x + x1) - a y1 has three).
        const float y = b_ * x + (b_ * x1_ - a_ * y1_);
        x1_ = x;
        y1_ = y;
        return y;
    }

private:
    bool enabled_ = false;
    float b_ = 0.0f, a_ = 0.0f, x1_ = 0.0f, y1_ = 0.0f;
};

// Seeded noise without libm: one xorshift64 step (Marsaglia's 13, 7, 17) per
// sample, its four 16-bit fields taken as four uniforms and summed (Irwin–
// Hall of 4) — a bell-shaped, bounded (±3.46 sigma) approximation of Gaussian
// sensor noise, bit-identical on every platform. The fields are summed as
// integers (exact) and converted once: one generator step and one conversion
// instead of four of each (the sensor noise had been the costliest part of
// the simulated stage on the host).
class SeededNoise {
public:
    // Any seed, including 0, gives a non-zero state (kSeedMix's high half).
    void seed(uint32_t s) { state_ = kSeedMix ^ s; }
    float next_unit() {
        const uint64_t x = next_u64();
        const uint32_t sum = static_cast<uint32_t>(x & 0xFFFFu) + static_cast<uint32_t>((x >> 16) & 0xFFFFu) +
                             static_cast<uint32_t>((x >> 32) & 0xFFFFu) + static_cast<uint32_t>(x >> 48);
        // Field k / 65536 (k = 0 .. 65535) has mean (1 - 2^-16) / 2 and
        // variance (1 - 2^-32) / 12, so (sum + 2) / 65536 - 2 has mean 0 and
        // variance (1 - 2^-32) / 3: scaled by sqrt(3). sum + 2 < 2^24 and the
        // power-of-two scale make the first two operations exact.
        return (static_cast<float>(sum + 2u) * (1.0f / 65536.0f) - 2.0f) * 1.7320508f;
    }

private:
    static constexpr uint64_t kSeedMix = 0x9E3779B97F4A7C15ull;
    uint64_t next_u64() {
        state_ ^= state_ << 13;
        state_ ^= state_ >> 7;
        state_ ^= state_ << 17;
        return state_;
    }
    uint64_t state_ = kSeedMix;
};

class StageModel {
public:
    Status configure(const StageConfig& c) {
        if (!is_finite(c.rate_Hz) || !(c.rate_Hz > 0.0f)) return error("rate_Hz", "must be > 0");
        Converter dac, adc;
        if (const Status s = dac.configure(c.dac); !s.ok()) return in_group("dac", s);
        if (const Status s = adc.configure(c.adc); !s.ok()) return in_group("adc", s);
        const AmplifierConfig& a = c.amplifier;
        if (!is_finite(a.gain)) return in_group("amplifier", error("gain", "must be finite"));
        if (!(a.input_min_V < a.input_max_V))
            return in_group("amplifier", error("input_max_V", "must be > input_min_V"));
        if (!(a.output_min_V < a.output_max_V))
            return in_group("amplifier", error("output_max_V", "must be > output_min_V"));
        FirstOrderLag amp_lag, sensor_lag;
        if (const Status s = amp_lag.configure(a.bandwidth_Hz, c.rate_Hz); !s.ok()) return in_group("amplifier", s);
        if (const Status s = sensor_lag.configure(c.sensor.bandwidth_Hz, c.rate_Hz); !s.ok())
            return in_group("sensor", s);
        if (!is_finite(c.sensor.gain) || c.sensor.gain == 0.0f)
            return in_group("sensor", error("gain", "must be finite and non-zero"));
        if (!is_finite(c.sensor.offset_um) || c.sensor.offset_um < -1e3f || c.sensor.offset_um > 1e3f)
            return in_group("sensor", error("offset_um", "must be finite and in [-1000, 1000] um"));
        if (!is_finite(c.sensor.gain_error) || c.sensor.gain_error < -0.5f || c.sensor.gain_error > 0.5f)
            return in_group("sensor", error("gain_error", "must be finite and in [-0.5, 0.5]"));
        MainsPickup mains;
        if (const Status s = mains.configure(c.sensor.mains, c.rate_Hz); !s.ok()) {
            Status m = in_group("sensor", s);
            m.field = s.field[0] == 'f' ? "mains.frequency_Hz" : (s.field[0] == 'c' ? "mains.count" : "mains.amplitudes_um");
            return m;
        }
        if (!is_finite(c.sensor.noise_rms) || c.sensor.noise_rms < 0.0f)
            return in_group("sensor", error("noise_rms", "must be finite and >= 0"));
        HammersteinPlant plant;
        if (const Status s = plant.configure(c.plant, c.rate_Hz); !s.ok()) return in_group("plant", s);
        config_ = c;
        amp_unity_ = a.gain == 1.0f;
        // The DAC's output never leaves [dac.min, dac.max] (NaN reads as
        // min): when that lies within the amplifier's input range, its clamp
        // changes nothing and is skipped.
        amp_input_clamp_ = !(c.dac.min >= a.input_min_V && c.dac.max <= a.input_max_V);
        // The sensor's actual gain; exactly `gain` without a gain error.
        sensor_gain_ = c.sensor.gain * (1.0f + c.sensor.gain_error);
        sensor_unity_ = sensor_gain_ == 1.0f;
        sensor_extra_ = c.sensor.offset_um != 0.0f || mains.enabled();
        mains_ = mains;
        dac_ = dac;
        adc_ = adc;
        amp_lag_ = amp_lag;
        sensor_lag_ = sensor_lag;
        plant_ = plant;
        reset();
        return ok_status();
    }

    void reset() {
        amp_lag_.reset();
        sensor_lag_.reset();
        plant_.reset();
        noise_.seed(config_.sensor.seed);
        mains_.reset();
        v_piezo_V_ = x_um_ = 0.0f;
    }

    // One sample: the controller's command (V) in, the ADC reading out (in
    // sensor units; divide by sensor.gain for µm).
    float step(float u_V) { return sense(actuate(u_V)); }

    // The first half of step(): the command (V) through the DAC, the
    // amplifier and the plant; returns the displacement (µm) of this sample.
    // A stage of coupled axes (axes/coupled_stage.hpp) adds the other axes'
    // contributions before the sensor reads it.
    float actuate(float u_V) {
        const AmplifierConfig& a = config_.amplifier;
        float v = dac_.apply(u_V);
        v = clamp(v, a.input_min_V, a.input_max_V);
        // A gain of exactly 1 is skipped: x * 1 is x in IEEE arithmetic, and
        // the multiply would sit on the loop's dependency chain.
        v = amp_lag_.apply(amp_unity_ ? v : a.gain * v);
        v_piezo_V_ = clamp(v, a.output_min_V, a.output_max_V);
        x_um_ = plant_.step(v_piezo_V_);
        return x_um_;
    }

    // The second half of step(): the sensor (gain, bandwidth, offset, mains,
    // noise) and the ADC reading a position (µm); returns the reading in
    // sensor units. Call once per sample, after actuate().
    float sense(float x_um) {
        float s = sensor_lag_.apply(sensor_unity_ ? x_um : sensor_gain_ * x_um);
        if (sensor_extra_) s = s + sensor_gain_ * (config_.sensor.offset_um + mains_.next_um());
        if (config_.sensor.noise_rms > 0.0f) s = s + config_.sensor.noise_rms * noise_.next_unit();
        return adc_.apply(s);
    }

    float piezo_voltage_V() const { return v_piezo_V_; }  // last sample
    float displacement_um() const { return x_um_; }       // true position, last sample
    const StageConfig& config() const { return config_; }

private:
    static float clamp(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }

    StageConfig config_{};
    Converter dac_{}, adc_{};
    FirstOrderLag amp_lag_{}, sensor_lag_{};
    HammersteinPlant plant_{};
    SeededNoise noise_{};
    MainsPickup mains_{};
    float sensor_gain_ = 1.0f;                     // gain (1 + gain_error)
    bool sensor_extra_ = false;                    // an offset or mains pickup
    float v_piezo_V_ = 0.0f;
    float x_um_ = 0.0f;
    bool amp_unity_ = true, sensor_unity_ = true;  // gains of exactly 1
    bool amp_input_clamp_ = true;                  // the DAC range exceeds the amplifier's input range
};

}  // namespace piezoloop
