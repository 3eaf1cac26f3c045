// The further axes of an emulated board's stage: a stage of two or three
// coupled axes (coupled_stage.hpp) is the emulation profile
// (emulation_profile.hpp: the loop rate, axis 0's full scales and stage)
// plus this blob, which QEMU's generic loader puts at
// kEmulationAxesProfileAddress beside it. Without it the board runs one
// axis, as before; with it, the servo image runs `axes` axes against the
// coupled stage (firmware/app/servo_axes.cpp).
//
// Layout, little-endian, no padding (version 2; version 1 carried the
// stage block of the emulation profile's version 2, without the output map):
//   header, 16 bytes: the stored-blob header (blob_header.hpp), magic
//     0x58415A50 ("PZAX" in memory order), version 2, body length
//     kEmulationAxesBodyBytes, CRC-32 of the body
//   body, kEmulationAxesBodyBytes bytes
//     u8 axes (2 or 3)
//     2 x axis block (axes 1 and 2; both travel, the second unused with
//       two axes): f32 position_full_scale_um, f32 voltage_full_scale_V,
//       the stage block of the emulation profile (profile_detail::
//       write_stage, kEmulationStageBytes)
//     u8 paths (0 .. 6)
//     6 x path (all travel): u8 from, u8 to, u8 sections,
//       2 x (f64 b0, b1, b2, a1, a2)
// Validation: every axis's stage at the profile's loop rate and accepted
// by CoupledStage::configure with axis 0 the profile's stage (its Status
// names "axis[i]..." or "coupling[k]..."); full scales finite and > 0.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "piezoloop/axes/coupled_stage.hpp"
#include "piezoloop/blob_header.hpp"
#include "piezoloop/emulation_profile.hpp"
#include "piezoloop/link/wire.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

struct EmulationAxesProfile {
    int axes = 2;  // 2 .. kMaxStageAxes
    // Axis i's full scales (index 0: the emulation profile's, not travelling here).
    std::array<float, kMaxStageAxes> position_full_scale_um{};
    std::array<float, kMaxStageAxes> voltage_full_scale_V{};
    // axis[0] is the emulation profile's stage; axis[1..] and the paths travel.
    CoupledStageConfig stage{};
};

// In the 16 KiB the QEMU images' memory.ld leave out at the top of SSRAM1,
// below the board cases (board_case.hpp) and the profile.
inline constexpr uint32_t kEmulationAxesProfileAddress = 0x003FC000u;
inline constexpr std::size_t kEmulationAxesProfileMaxBytes = 2048;
inline constexpr uint32_t kEmulationAxesMagic = 0x58415A50u;  // "PZAX"
inline constexpr uint16_t kEmulationAxesVersion = 2;
inline constexpr BlobKind kEmulationAxesBlob{kEmulationAxesMagic, kEmulationAxesVersion,
                                             "must be 0x58415A50 (\"PZAX\")", "must be 2"};
inline constexpr std::size_t kEmulationStageBytes = kEmulationProfileBodyBytes - 12;
inline constexpr std::size_t kEmulationAxesBodyBytes =
    1 + (kMaxStageAxes - 1) * (8 + kEmulationStageBytes) + 1 + kMaxCouplingPaths * (3 + kMaxCouplingSections * 40);

static_assert(kEmulationAxesBodyBytes == 1726, "the length decode_axes_profile's message states");
static_assert(kBlobHeaderBytes + kEmulationAxesBodyBytes <= kEmulationAxesProfileMaxBytes);
static_assert(kEmulationAxesProfileAddress + kEmulationAxesProfileMaxBytes <= 0x003FE000u,
              "below the board cases' slots (board_case.hpp)");

namespace axes_profile_detail {

inline uint8_t small(int v) { return static_cast<uint8_t>(v < 0 || v > 255 ? 255 : v); }

inline void write_body(link::Writer& w, const EmulationAxesProfile& p) {
    w.u8(small(p.axes));
    for (int i = 1; i < kMaxStageAxes; ++i) {
        const std::size_t k = static_cast<std::size_t>(i);
        w.f32(p.position_full_scale_um[k]);
        w.f32(p.voltage_full_scale_V[k]);
        profile_detail::write_stage(w, p.stage.axis[k]);
    }
    w.u8(small(p.stage.paths));
    for (const CouplingPath& c : p.stage.coupling) {
        w.u8(small(c.from)); w.u8(small(c.to)); w.u8(small(c.sections));
        for (const SosSection& q : c.filter) { w.f64(q.b0); w.f64(q.b1); w.f64(q.b2); w.f64(q.a1); w.f64(q.a2); }
    }
}

inline void read_body(link::Reader& r, EmulationAxesProfile& p) {
    p.axes = r.u8();
    for (int i = 1; i < kMaxStageAxes; ++i) {
        const std::size_t k = static_cast<std::size_t>(i);
        p.position_full_scale_um[k] = r.f32();
        p.voltage_full_scale_V[k] = r.f32();
        profile_detail::read_stage(r, p.stage.axis[k]);
    }
    p.stage.paths = r.u8();
    for (CouplingPath& c : p.stage.coupling) {
        c.from = r.u8(); c.to = r.u8(); c.sections = r.u8();
        for (SosSection& q : c.filter) { q.b0 = r.f64(); q.b1 = r.f64(); q.b2 = r.f64(); q.a1 = r.f64(); q.a2 = r.f64(); }
    }
}

inline constexpr const char* kFullScaleGroups[kMaxStageAxes] = {"axis[0]", "axis[1]", "axis[2]"};

}  // namespace axes_profile_detail

// The axes with axis 0 taken from the (valid) emulation profile; errors
// name the axis or path ("axis[1].plant", "coupling[2]", ...). `scratch`
// is configured with the stage (a CoupledStage is 9 KiB: a board keeps one
// in static storage rather than on its stack).
inline Status validate(const EmulationAxesProfile& p, const EmulationProfile& first, CoupledStage& scratch) {
    if (p.axes < 2 || p.axes > kMaxStageAxes) return error("axes", "must be 2 or 3");
    for (int i = 1; i < p.axes; ++i) {
        const std::size_t k = static_cast<std::size_t>(i);
        const char* group = axes_profile_detail::kFullScaleGroups[i];
        if (!is_finite(p.position_full_scale_um[k]) || !(p.position_full_scale_um[k] > 0.0f))
            return in_group(group, error("position_full_scale_um", "must be finite and > 0"));
        if (!is_finite(p.voltage_full_scale_V[k]) || !(p.voltage_full_scale_V[k] > 0.0f))
            return in_group(group, error("voltage_full_scale_V", "must be finite and > 0"));
    }
    CoupledStageConfig c = p.stage;
    c.axes = p.axes;
    c.axis[0] = first.stage;
    return scratch.configure(c);
}

// Writes the blob (header + body) into out; its size, 0 if out is too
// small. Values are not validated: a test can write a bad blob.
inline std::size_t encode_axes_profile(const EmulationAxesProfile& p, std::span<uint8_t> out) {
    const std::size_t total = kBlobHeaderBytes + kEmulationAxesBodyBytes;
    if (out.size() < total) return 0;
    const std::span<uint8_t> body = out.subspan(kBlobHeaderBytes, kEmulationAxesBodyBytes);
    link::Writer wb(body);
    axes_profile_detail::write_body(wb, p);
    if (!wb.ok() || wb.size() != kEmulationAxesBodyBytes) return 0;
    if (!write_blob_header(kEmulationAxesBlob, body, out)) return 0;
    return total;
}

inline bool axes_profile_present(std::span<const uint8_t> in) { return blob_present(in, kEmulationAxesMagic); }

// Reads and validates the blob against the profile it belongs to; `out`
// (axis 0 filled in from `first`) is written only when all is valid.
// Errors name the header field or the value's.
inline Status decode_axes_profile(std::span<const uint8_t> in, const EmulationProfile& first,
                                  EmulationAxesProfile& out, CoupledStage& scratch) {
    BlobHeader h;
    if (const Status s = read_blob_header(in, kEmulationAxesBlob, h); !s.ok()) return s;
    if (h.length != kEmulationAxesBodyBytes) return error("length", "body must be 1726 bytes (version 2)");
    std::span<const uint8_t> body;
    if (const Status s = blob_body(in, h, body); !s.ok()) return s;
    EmulationAxesProfile p;
    link::Reader r(body);
    axes_profile_detail::read_body(r, p);
    if (!r.complete()) return error("length", "body does not match the version 2 layout");
    if (const Status s = validate(p, first, scratch); !s.ok()) return s;
    p.stage.axes = p.axes;
    p.stage.axis[0] = first.stage;
    p.position_full_scale_um[0] = first.position_full_scale_um;
    p.voltage_full_scale_V[0] = first.voltage_full_scale_V;
    out = p;
    return ok_status();
}

}  // namespace piezoloop
