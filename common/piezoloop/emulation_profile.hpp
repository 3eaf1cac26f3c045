// The emulated boards' analog front end and stage, plugged in at boot like
// hardware: QEMU's generic loader puts a profile blob into RAM before reset
// (-device loader,file=PROFILE.bin,addr=kEmulationProfileAddress) and the
// servo image reads it there. A valid profile sets the loop rate, the
// converter full scales (the pipeline's SignalScales) and the stage model
// (StageConfig, the host simulator's float stage); hard output limits stay
// the board's compiled-in ones. No profile (no magic) means the reference
// stage at 100 kHz.
//
// Layout, little-endian, no padding (version 3):
//   header, 16 bytes: the stored-blob header (blob_header.hpp), magic
//     0x4D455A50 ("PZEM" in memory order), version 3, body length
//     kEmulationProfileBodyBytes, CRC-32 of the body
//   body, kEmulationProfileBodyBytes bytes
//     u32 loop_rate_Hz, f32 position_full_scale_um, f32 voltage_full_scale_V
//     stage: f32 rate_Hz
//       dac:       i32 bits, f32 min, f32 max
//       amplifier: f32 gain, input_min_V, input_max_V, output_min_V,
//                  output_max_V, bandwidth_Hz
//       plant:     u8 hysteresis (0 none, 1 PI, 2 Dahl)
//                  pi: f32 input_gain, input_offset, p0, u8 count,
//                      16 x f32 thresholds, 16 x f32 weights (all 16 travel)
//                  dahl: f32 alpha1, alpha2, beta1, beta2, gamma_a, ga
//                  f32 linear_gain_um_per_V, u8 sections,
//                  6 x (f64 b0, b1, b2, a1, a2) dynamics (all 6 travel)
//       sensor:    f32 gain, bandwidth_Hz, noise_rms, u32 seed
//       adc:       i32 bits, f32 min, f32 max
//       sensor, real-stage effects: f32 offset_um, gain_error,
//                  mains.frequency_Hz, u8 mains.count,
//                  8 x f32 mains.amplitudes_um (all 8 travel)
//       plant, real-stage effects: f32 creep.percent_per_decade,
//                  creep.from_s, creep.to_s, f32 drift_um_per_s
//       plant, output map: u8 output_map.count, 8 x f32 thresholds_um,
//                  8 x f32 weights (all 8 travel)
// (Version 1 ended after the adc, 491 bytes: the stage without offset,
// gain error, mains, creep and drift; version 2 after the drift, 552 bytes.
// An older profile is refused by its version, not read with those effects
// off.)
// Floats travel as IEEE-754 bit patterns (link/wire.hpp), so a NaN arrives
// as written and is rejected by the validation, which names the field.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "piezoloop/blob_header.hpp"
#include "piezoloop/det_math.hpp"
#include "piezoloop/link/wire.hpp"
#include "piezoloop/stage_model.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

struct EmulationProfile {
    uint32_t loop_rate_Hz = 100000;
    float position_full_scale_um = 50.0f;  // Q31 full scale of r, y, e
    float voltage_full_scale_V = 12.0f;    // Q31 full scale of u
    StageConfig stage{};                   // stage.rate_Hz == loop_rate_Hz
};

// Where the emulated boards find the profile: the last 1 KiB of SSRAM1
// (0x00000000, 4 MiB on both mps2-an385 and mps2-an500), which the images'
// memory.ld leave out of their code region -- RAM that nothing else writes,
// like a calibration page at the end of flash.
inline constexpr uint32_t kEmulationProfileAddress = 0x003FFC00u;
inline constexpr std::size_t kEmulationProfileMaxBytes = 1024;
inline constexpr uint32_t kEmulationProfileMagic = 0x4D455A50u;  // "PZEM"
inline constexpr uint16_t kEmulationProfileVersion = 3;
inline constexpr BlobKind kEmulationProfileBlob{kEmulationProfileMagic, kEmulationProfileVersion,
                                                "must be 0x4D455A50 (\"PZEM\")", "must be 3"};
inline constexpr std::size_t kEmulationProfileHeaderBytes = kBlobHeaderBytes;
inline constexpr std::size_t kEmulationProfileBodyBytes = 617;
// The MPS2 tick timer clock (CMSDK TIMER0 on the 25 MHz APB): the loop rate
// must divide it into a whole number of counts.
inline constexpr uint32_t kEmulationTimerClock_Hz = 25'000'000;
// Loop rates the emulated boards run: above 200 kHz the tick (and the
// stage model after it) no longer fits a period under -icount shift=0.
inline constexpr uint32_t kEmulationMinRate_Hz = 100;
inline constexpr uint32_t kEmulationMaxRate_Hz = 200'000;

static_assert(kEmulationProfileHeaderBytes + kEmulationProfileBodyBytes <= kEmulationProfileMaxBytes);

namespace profile_detail {

// The stage block: everything of the body after the full scales (also
// each further axis's stage in an axes profile, axes/emulation_axes_profile.hpp).
inline void write_stage(link::Writer& w, const StageConfig& s) {
    w.f32(s.rate_Hz);
    w.i32(s.dac.bits); w.f32(s.dac.min); w.f32(s.dac.max);
    const AmplifierConfig& a = s.amplifier;
    w.f32(a.gain); w.f32(a.input_min_V); w.f32(a.input_max_V);
    w.f32(a.output_min_V); w.f32(a.output_max_V); w.f32(a.bandwidth_Hz);
    const PlantConfig& pl = s.plant;
    w.u8(static_cast<uint8_t>(pl.hysteresis));
    w.f32(pl.pi.input_gain); w.f32(pl.pi.input_offset); w.f32(pl.pi.p0);
    // A count outside [0, 255] cannot travel; 255 is rejected on decode.
    w.u8(static_cast<uint8_t>(pl.pi.count < 0 || pl.pi.count > 255 ? 255 : pl.pi.count));
    for (const float t : pl.pi.thresholds) w.f32(t);
    for (const float x : pl.pi.weights) w.f32(x);
    const DahlParams& d = pl.dahl;
    w.f32(d.alpha1); w.f32(d.alpha2); w.f32(d.beta1); w.f32(d.beta2); w.f32(d.gamma_a); w.f32(d.ga);
    w.f32(pl.linear_gain_um_per_V);
    w.u8(static_cast<uint8_t>(pl.sections < 0 || pl.sections > 255 ? 255 : pl.sections));
    for (const SosSection& q : pl.dynamics) { w.f64(q.b0); w.f64(q.b1); w.f64(q.b2); w.f64(q.a1); w.f64(q.a2); }
    w.f32(s.sensor.gain); w.f32(s.sensor.bandwidth_Hz); w.f32(s.sensor.noise_rms); w.u32(s.sensor.seed);
    w.i32(s.adc.bits); w.f32(s.adc.min); w.f32(s.adc.max);
    w.f32(s.sensor.offset_um); w.f32(s.sensor.gain_error); w.f32(s.sensor.mains.frequency_Hz);
    const int mains = s.sensor.mains.count;
    w.u8(static_cast<uint8_t>(mains < 0 || mains > 255 ? 255 : mains));
    for (const float m : s.sensor.mains.amplitudes_um) w.f32(m);
    w.f32(pl.creep.percent_per_decade); w.f32(pl.creep.from_s); w.f32(pl.creep.to_s);
    w.f32(pl.drift_um_per_s);
    const OutputMap& om = pl.output_map;
    w.u8(static_cast<uint8_t>(om.count < 0 || om.count > 255 ? 255 : om.count));
    for (const float t : om.thresholds_um) w.f32(t);
    for (const float x : om.weights) w.f32(x);
}

inline void write_body(link::Writer& w, const EmulationProfile& p) {
    w.u32(p.loop_rate_Hz);
    w.f32(p.position_full_scale_um);
    w.f32(p.voltage_full_scale_V);
    write_stage(w, p.stage);
}

inline void read_stage(link::Reader& r, StageConfig& s) {
    s.rate_Hz = r.f32();
    s.dac.bits = r.i32(); s.dac.min = r.f32(); s.dac.max = r.f32();
    AmplifierConfig& a = s.amplifier;
    a.gain = r.f32(); a.input_min_V = r.f32(); a.input_max_V = r.f32();
    a.output_min_V = r.f32(); a.output_max_V = r.f32(); a.bandwidth_Hz = r.f32();
    PlantConfig& pl = s.plant;
    pl.hysteresis = static_cast<HysteresisKind>(r.u8());
    pl.pi.input_gain = r.f32(); pl.pi.input_offset = r.f32(); pl.pi.p0 = r.f32();
    pl.pi.count = r.u8();
    for (float& t : pl.pi.thresholds) t = r.f32();
    for (float& x : pl.pi.weights) x = r.f32();
    DahlParams& d = pl.dahl;
    d.alpha1 = r.f32(); d.alpha2 = r.f32(); d.beta1 = r.f32(); d.beta2 = r.f32(); d.gamma_a = r.f32(); d.ga = r.f32();
    pl.linear_gain_um_per_V = r.f32();
    pl.sections = r.u8();
    for (SosSection& q : pl.dynamics) { q.b0 = r.f64(); q.b1 = r.f64(); q.b2 = r.f64(); q.a1 = r.f64(); q.a2 = r.f64(); }
    s.sensor.gain = r.f32(); s.sensor.bandwidth_Hz = r.f32(); s.sensor.noise_rms = r.f32(); s.sensor.seed = r.u32();
    s.adc.bits = r.i32(); s.adc.min = r.f32(); s.adc.max = r.f32();
    s.sensor.offset_um = r.f32(); s.sensor.gain_error = r.f32(); s.sensor.mains.frequency_Hz = r.f32();
    s.sensor.mains.count = r.u8();
    for (float& m : s.sensor.mains.amplitudes_um) m = r.f32();
    pl.creep.percent_per_decade = r.f32(); pl.creep.from_s = r.f32(); pl.creep.to_s = r.f32();
    pl.drift_um_per_s = r.f32();
    OutputMap& om = pl.output_map;
    om.count = r.u8();
    for (float& t : om.thresholds_um) t = r.f32();
    for (float& x : om.weights) x = r.f32();
}

inline void read_body(link::Reader& r, EmulationProfile& p) {
    p.loop_rate_Hz = r.u32();
    p.position_full_scale_um = r.f32();
    p.voltage_full_scale_V = r.f32();
    read_stage(r, p.stage);
}

}  // namespace profile_detail

// Everything a profile's values must satisfy; the stage part with
// StageModel::configure's own rules (its Status names the stage group and
// field, e.g. group "plant", field "sections").
inline Status validate(const EmulationProfile& p) {
    if (p.loop_rate_Hz < kEmulationMinRate_Hz || p.loop_rate_Hz > kEmulationMaxRate_Hz)
        return error("loop_rate_Hz", "must be in [100, 200000] Hz");
    if (kEmulationTimerClock_Hz % p.loop_rate_Hz != 0u)
        return error("loop_rate_Hz", "must divide the 25 MHz timer clock");
    if (!is_finite(p.position_full_scale_um) || !(p.position_full_scale_um > 0.0f))
        return error("position_full_scale_um", "must be finite and > 0");
    if (!is_finite(p.voltage_full_scale_V) || !(p.voltage_full_scale_V > 0.0f))
        return error("voltage_full_scale_V", "must be finite and > 0");
    if (!(p.stage.rate_Hz == static_cast<float>(p.loop_rate_Hz)))
        return in_group("stage", error("rate_Hz", "must equal loop_rate_Hz"));
    StageModel scratch;
    if (const Status s = scratch.configure(p.stage); !s.ok()) return s.group == nullptr ? in_group("stage", s) : s;
    return ok_status();
}

// Writes the profile (header + body) into out; returns its size, 0 if out
// is too small. Values are not validated: a test can write a bad profile.
inline std::size_t encode_profile(const EmulationProfile& p, std::span<uint8_t> out) {
    const std::size_t total = kEmulationProfileHeaderBytes + kEmulationProfileBodyBytes;
    if (out.size() < total) return 0;
    const std::span<uint8_t> body = out.subspan(kEmulationProfileHeaderBytes, kEmulationProfileBodyBytes);
    link::Writer wb(body);
    profile_detail::write_body(wb, p);
    if (!wb.ok() || wb.size() != kEmulationProfileBodyBytes) return 0;  // layout and constant disagree
    if (!write_blob_header(kEmulationProfileBlob, body, out)) return 0;
    return total;
}

// True if `in` starts with the profile magic (a profile is present, valid or not).
inline bool profile_present(std::span<const uint8_t> in) { return blob_present(in, kEmulationProfileMagic); }

// Reads and validates a profile from the start of `in` (which may extend
// beyond it, e.g. the whole reserved RAM area). `out` is written only when
// everything is valid. Errors name the header field ("magic", "version",
// "reserved", "length", "crc") or the value's field.
inline Status decode_profile(std::span<const uint8_t> in, EmulationProfile& out) {
    BlobHeader h;
    if (const Status s = read_blob_header(in, kEmulationProfileBlob, h); !s.ok()) return s;
    if (h.length != kEmulationProfileBodyBytes) return error("length", "body must be 617 bytes (version 3)");
    std::span<const uint8_t> body;
    if (const Status s = blob_body(in, h, body); !s.ok()) return s;
    EmulationProfile p;
    link::Reader r(body);
    profile_detail::read_body(r, p);
    if (!r.complete()) return error("length", "body does not match the version 3 layout");
    if (const Status s = validate(p); !s.ok()) return s;
    out = p;
    return ok_status();
}

}  // namespace piezoloop
