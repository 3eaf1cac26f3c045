// A "board case": everything one scenario run needs on an emulated board,
// written by the host (`piezoloop sim ... --board-case FILE`, for exactly
// the run it simulates) and put into RAM by QEMU's generic loader before
// reset (-device loader,file=CASE.bin,addr=kBoardCaseAddress + i *
// kBoardCaseSlotBytes). The self-test image (firmware/app/selftest.cpp)
// runs every valid case it finds there and prints its log hash, which must
// equal the simulator's.
//
// Nothing is serialised a second time: the stage, loop rate and full scales
// are the emulation profile's encoding (emulation_profile.hpp, with its own
// header and CRC), the controller and the reference are the link's
// parameter groups (link/messages.hpp: the very bytes `piezoloop set`
// sends).
//
// Layout, little-endian, no padding (version 1):
//   header, 16 bytes: the stored-blob header (blob_header.hpp), magic
//     0x43425A50 ("PZBC" in memory order), version 1, body length (at most
//     a slot less the header), CRC-32 of the body
//   body (variable: the link groups carry only the operators / table
//   points in use)
//     48 bytes  name, "<scenario>/<case>", zero-padded (at least one zero)
//     u32       ticks: length of the run
//     u32       metric_start_tick: tracking figures over [this, ticks)
//               (the simulator's steady-state window, its last period)
//     u8        sample: link::SampleFormat the case was built for (0 float,
//               1 Q31); the Q31 build scales the feedback sections
//     profile   encode_profile(): header + body (568 bytes)
//     groups    link LimitsParams, FeedforwardParams, FeedbackParams,
//               RepetitiveParams, TrajectoryParams, each its write()
// The hard output limits are not in the blob: they are the board's, and the
// host clips the case's limits to kEmulatedBoardHardLimits (the QEMU
// boards' compiled-in ones; the self-test asserts at compile time that they
// agree). The loop rate is the profile's.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "piezoloop/blob_header.hpp"
#include "piezoloop/det_math.hpp"
#include "piezoloop/emulation_profile.hpp"
#include "piezoloop/limits.hpp"
#include "piezoloop/link/messages.hpp"
#include "piezoloop/link/wire.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/status.hpp"
#include "piezoloop/trajectory.hpp"

namespace piezoloop {

inline constexpr std::size_t kBoardCaseNameBytes = 48;

struct BoardCase {
    std::array<char, kBoardCaseNameBytes> name{};  // zero-terminated
    uint32_t ticks = 0;
    uint32_t metric_start_tick = 0;
    link::SampleFormat sample = link::SampleFormat::kFloat32;
    EmulationProfile profile{};
    PipelineParams params{};
    link::TrajectoryParams trajectory{};
};

// Where the QEMU boards find board cases: kBoardCaseSlots slots of
// kBoardCaseSlotBytes at the top of SSRAM1, below the emulation profile,
// left out of the images by their memory.ld (firmware/bsp/qemu-m*/).
inline constexpr uint32_t kBoardCaseAddress = 0x003FE000u;
inline constexpr std::size_t kBoardCaseSlotBytes = 2048;
inline constexpr int kBoardCaseSlots = 3;
inline constexpr uint32_t kBoardCaseMagic = 0x43425A50u;  // "PZBC"
inline constexpr uint16_t kBoardCaseVersion = 1;
inline constexpr BlobKind kBoardCaseBlob{kBoardCaseMagic, kBoardCaseVersion, "must be 0x43425A50 (\"PZBC\")",
                                         "must be 1"};
inline constexpr std::size_t kBoardCaseHeaderBytes = kBlobHeaderBytes;
static_assert(kBoardCaseAddress + kBoardCaseSlots * kBoardCaseSlotBytes <= kEmulationProfileAddress);

// What the QEMU boards can run, stated here so the host refuses a case
// before writing it (firmware/app/selftest.cpp asserts both against the
// firmware's own constants):
//   hard output limits of firmware/bsp/mps2/board_config.hpp;
//   RC delay line of firmware/app/control_config.hpp (kRcCapacity).
inline constexpr HardLimits kEmulatedBoardHardLimits{-10.0f, 10.0f, 2.0e5f};
inline constexpr int kEmulatedBoardRcCapacity = 2048;

namespace board_case_detail {

inline void write_body(link::Writer& w, const BoardCase& c, std::span<const uint8_t> profile) {
    w.text(c.name.data(), kBoardCaseNameBytes);
    w.u32(c.ticks);
    w.u32(c.metric_start_tick);
    w.u8(static_cast<uint8_t>(c.sample));
    for (const uint8_t b : profile) w.u8(b);
    const PipelineParams& p = c.params;
    params::write_group(w, params::limits_of(p));
    params::write_group(w, params::feedforward_of(p));
    params::write_group(w, params::feedback_of(p));
    params::write_group(w, params::rc_of(p));
    params::write_group(w, c.trajectory);
}

// A group read from the body; a value the layout cannot hold (an operator
// or table count beyond the link's limit, a boolean not 0 or 1) names the
// group.
template <class G>
Status read_group(link::Reader& r, G& g, const char* group) {
    params::read_group(r, g);
    if (!r.ok()) return error("length", "body ends inside a parameter group");
    if (r.bad_value()) return in_group(group, error("encoding", "a count beyond the link's limit or a boolean not 0 or 1"));
    return ok_status();
}

}  // namespace board_case_detail

// Writes the case (header + body) into out; returns its size, 0 if out is
// too small or the profile cannot be encoded. Values are not validated: a
// test can write a bad case.
inline std::size_t encode_board_case(const BoardCase& c, std::span<uint8_t> out) {
    std::array<uint8_t, kEmulationProfileHeaderBytes + kEmulationProfileBodyBytes> profile{};
    if (encode_profile(c.profile, profile) != profile.size()) return 0;
    if (out.size() < kBoardCaseHeaderBytes) return 0;
    link::Writer wb(out.subspan(kBoardCaseHeaderBytes));
    board_case_detail::write_body(wb, c, profile);
    if (!wb.ok()) return 0;
    const std::span<const uint8_t> body(out.data() + kBoardCaseHeaderBytes, wb.size());
    if (!write_blob_header(kBoardCaseBlob, body, out)) return 0;
    return kBoardCaseHeaderBytes + body.size();
}

// True if `in` starts with the board-case magic (a case is present, valid or not).
inline bool board_case_present(std::span<const uint8_t> in) { return blob_present(in, kBoardCaseMagic); }

// Reads and checks a case from the start of `in` (which may extend beyond
// it, e.g. a whole slot). `out` is written only when everything is valid.
// Errors name the header field ("magic", "version", "reserved", "length",
// "crc"), the case's own fields ("name", "ticks", "metric_start_tick",
// "sample"), the profile's (group "profile" for its header, else the stage
// group as decode_profile names it) or a parameter group ("encoding").
// The parameter values themselves are the pipeline's to validate when the
// board stages them (Pipeline::stage names the field).
inline Status decode_board_case(std::span<const uint8_t> in, BoardCase& out) {
    BlobHeader h;
    if (const Status s = read_blob_header(in, kBoardCaseBlob, h); !s.ok()) return s;
    if (h.length > kBoardCaseSlotBytes - kBoardCaseHeaderBytes)
        return error("length", "body must fit a 2048-byte slot with its header");
    std::span<const uint8_t> body;
    if (const Status s = blob_body(in, h, body); !s.ok()) return s;

    BoardCase c;
    link::Reader r(body);
    r.text(c.name.data(), c.name.size(), kBoardCaseNameBytes);
    c.ticks = r.u32();
    c.metric_start_tick = r.u32();
    const uint8_t sample = r.u8();
    constexpr std::size_t kProfileBytes = kEmulationProfileHeaderBytes + kEmulationProfileBodyBytes;
    if (r.remaining() < kProfileBytes) return error("length", "body ends before the emulation profile");
    const std::span<const uint8_t> profile = body.subspan(r.position(), kProfileBytes);
    for (std::size_t i = 0; i < kProfileBytes; ++i) (void)r.u8();
    link::LimitsParams limits;
    link::FeedforwardParams ff;
    link::FeedbackParams fb;
    link::RepetitiveParams rc;
    if (const Status s = board_case_detail::read_group(r, limits, "limits"); !s.ok()) return s;
    if (const Status s = board_case_detail::read_group(r, ff, "feedforward"); !s.ok()) return s;
    if (const Status s = board_case_detail::read_group(r, fb, "feedback"); !s.ok()) return s;
    if (const Status s = board_case_detail::read_group(r, rc, "rc"); !s.ok()) return s;
    if (const Status s = board_case_detail::read_group(r, c.trajectory, "trajectory"); !s.ok()) return s;
    if (!r.complete()) return error("length", "body longer than its fields (version 1 layout)");

    // Zero bytes pad the name field; a name is at least one printable
    // character and nothing but printable ASCII (it goes into JSON text).
    bool ended = false;
    for (std::size_t i = 0; i < kBoardCaseNameBytes; ++i) {
        const uint8_t ch = body[i];
        if (ch == 0) ended = true;
        else if (ended || ch < 0x20 || ch > 0x7E || ch == '"' || ch == '\\')
            return error("name", "printable ASCII without quotes or backslashes, zero-padded");
    }
    if (c.name[0] == '\0' || !ended) return error("name", "must have 1 to 47 characters");
    if (c.ticks == 0) return error("ticks", "must be >= 1");
    if (c.metric_start_tick >= c.ticks) return error("metric_start_tick", "must be < ticks");
    if (sample > static_cast<uint8_t>(link::SampleFormat::kQ31)) return error("sample", "must be 0 (float) or 1 (Q31)");
    c.sample = static_cast<link::SampleFormat>(sample);
    if (const Status s = decode_profile(profile, c.profile); !s.ok()) return s.group == nullptr ? in_group("profile", s) : s;

    params::set_group(c.params, limits);
    params::set_group(c.params, ff);
    params::set_group(c.params, fb);
    params::set_group(c.params, rc);
    out = c;
    return ok_status();
}

// The case's reference as the wave generator's configuration at the
// profile's loop rate, as link::Device turns a TrajectoryParams group into
// one. The table points into `c`, which must outlive the returned value.
inline TrajectoryConfig board_case_wave(const BoardCase& c) {
    return params::trajectory_config(c.trajectory, static_cast<float>(c.profile.loop_rate_Hz));
}

}  // namespace piezoloop
