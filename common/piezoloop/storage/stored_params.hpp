// The parameter set a board keeps in its storage (Save / Load, and at boot):
// the record format, and the checks that tell a usable record from a
// corrupt one or one written by another firmware.
//
// Layout, little-endian, no padding (format version 2):
//   header, 16 bytes: the stored-blob header (blob_header.hpp), magic
//     0x53505A50 ("PZPS" in memory order), version 2 (this format), body
//     length in bytes, CRC-32 of the body
//   body:
//     u8        link protocol version of the writer (link/messages.hpp)
//     char[16]  firmware version of the writer (HelloReply::firmware_version)
//     f32       loop rate the set was commissioned at, Hz
//     u8        axis count of the writer's board, 1..3
//     u8        group count
//     then per group: u8 group id, u8 axis, the group's layout
//       (params/wire_codec.hpp) -- byte for byte a SetParams body. Always
//       limits, feedforward, feedback and rc of every axis, and link,
//       input_matrix and output_matrix (axis 0); an axis's trajectory and
//       the recorder only once they have been set on the device (an unset
//       one is not a set to restore).
// A layout belongs to its firmware version, so a record is read only by the
// firmware version that wrote it; the loop rate is checked by the device
// (discrete-time coefficients belong to one rate).
//
// decode_stored_params() checks, in this order, and names the first failure:
//   nothing stored (no bytes, or erased flash: first word all ones) -> empty;
//   header "length" (shorter than the header), "magic", "reserved",
//   "length" (more than a record can hold, or cut short: the body extends
//   beyond the stored bytes), "crc"                               -> corrupt;
//   header "version" (another record format), body "protocol_version",
//   "firmware_version"                                            -> other firmware;
//   body "axis_count" (not 1..3), "groups" (unknown or repeated group, an
//   axis beyond the count or not 0 for a board group, a group missing, a
//   count beyond its array, bytes left over)                      -> corrupt.
// Format 1 (one axis, protocol 4) is refused by its header version.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

#include "piezoloop/blob_header.hpp"
#include "piezoloop/link/framing.hpp"
#include "piezoloop/link/messages.hpp"
#include "piezoloop/params/groups.hpp"
#include "piezoloop/params/wire_codec.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop::storage {

using link::StorageState;

inline constexpr uint32_t kStoredParamsMagic = 0x53505A50u;  // "PZPS"
inline constexpr uint16_t kStoredParamsVersion = 2;
inline constexpr BlobKind kStoredParamsBlob{kStoredParamsMagic, kStoredParamsVersion,
                                            "must be 0x53505A50 (\"PZPS\")",
                                            "record format 2 expected: written by another firmware"};
inline constexpr std::size_t kMaxStoredAxes = link::kMaxLinkAxes;
// Body bytes before the groups: protocol version, firmware version, rate, axis count, group count.
inline constexpr std::size_t kStoredParamsPreambleBytes = 1 + link::kNameSize + 4 + 1 + 1;
// Groups of one axis (limits, feedforward, feedback, rc, trajectory) and of the board.
inline constexpr std::size_t kStoredAxisGroups = 5;
inline constexpr std::size_t kStoredBoardGroups = 4;
// Every group travels in one SetParams body, so none is longer than kMaxBody.
inline constexpr std::size_t kStoredParamsMaxBodyBytes =
    kStoredParamsPreambleBytes + (kStoredAxisGroups * kMaxStoredAxes + kStoredBoardGroups) * link::kMaxBody;
inline constexpr std::size_t kStoredParamsMaxBytes = kBlobHeaderBytes + kStoredParamsMaxBodyBytes;

// One axis's groups.
struct StoredAxis {
    params::LimitsParams limits{};
    params::FeedforwardParams feedforward{};
    params::FeedbackParams feedback{};
    params::RepetitiveParams rc{};
    bool has_trajectory = false;
    params::TrajectoryParams trajectory{};
    bool operator==(const StoredAxis&) const = default;
};

// The whole set GetParams reports, as it is stored.
struct StoredParams {
    uint8_t protocol_version = link::kProtocolVersion;
    std::array<char, link::kNameSize> firmware_version{};
    float loop_rate_Hz = 0.0f;
    uint8_t axis_count = 1;
    std::array<StoredAxis, kMaxStoredAxes> axes{};  // the first axis_count
    bool has_recorder = false;
    params::RecorderParams recorder{};
    params::LinkParams link{};
    params::InputMatrixParams input_matrix{};
    params::OutputMatrixParams output_matrix{};
    bool operator==(const StoredParams&) const = default;
};

// Outcome of reading a record: the state the status reports and, unless
// usable, the check that failed.
struct RecordCheck {
    StorageState state = StorageState::kEmpty;
    Status why{};
};

namespace stored_detail {

template <class G>
constexpr G& slot(StoredParams& s, uint8_t axis) {
    StoredAxis& a = s.axes[axis];
    if constexpr (std::is_same_v<G, params::LimitsParams>) return a.limits;
    else if constexpr (std::is_same_v<G, params::FeedforwardParams>) return a.feedforward;
    else if constexpr (std::is_same_v<G, params::FeedbackParams>) return a.feedback;
    else if constexpr (std::is_same_v<G, params::RepetitiveParams>) return a.rc;
    else if constexpr (std::is_same_v<G, params::TrajectoryParams>) return a.trajectory;
    else if constexpr (std::is_same_v<G, params::RecorderParams>) return s.recorder;
    else if constexpr (std::is_same_v<G, params::InputMatrixParams>) return s.input_matrix;
    else if constexpr (std::is_same_v<G, params::OutputMatrixParams>) return s.output_matrix;
    else return s.link;
}

template <class G>
constexpr void write_one(link::Writer& w, const G& g, uint8_t axis = 0) {
    w.u8(static_cast<uint8_t>(G::kGroup));
    w.u8(axis);
    params::write_group(w, g);
}

constexpr bool same_text(const std::array<char, link::kNameSize>& a, const char* b) {
    std::array<char, link::kNameSize> t{};
    link::set_text(t, b);
    return a == t;
}

constexpr bool field_is(const Status& s, const char* name) {
    std::size_t i = 0;
    for (; s.field[i] != '\0' && name[i] != '\0'; ++i)
        if (s.field[i] != name[i]) return false;
    return s.field[i] == name[i];
}

inline RecordCheck corrupt(Status s) { return {StorageState::kCorrupt, s}; }
inline RecordCheck other_firmware(Status s) { return {StorageState::kOtherFirmware, s}; }

}  // namespace stored_detail

// Writes the record of `s` into out; returns its size, 0 if out is too small.
inline std::size_t encode_stored_params(const StoredParams& s, std::span<uint8_t> out) {
    if (out.size() < kBlobHeaderBytes) return 0;
    const std::span<uint8_t> body = out.subspan(kBlobHeaderBytes);
    link::Writer w(body);
    w.u8(s.protocol_version);
    w.text(s.firmware_version.data(), link::kNameSize);
    w.f32(s.loop_rate_Hz);
    if (s.axis_count < 1 || s.axis_count > kMaxStoredAxes) return 0;
    w.u8(s.axis_count);
    std::size_t count = 3 + (s.has_recorder ? 1 : 0);
    for (uint8_t a = 0; a < s.axis_count; ++a) count += 4 + (s.axes[a].has_trajectory ? 1 : 0);
    w.u8(static_cast<uint8_t>(count));
    for (uint8_t a = 0; a < s.axis_count; ++a) {
        const StoredAxis& x = s.axes[a];
        stored_detail::write_one(w, x.limits, a);
        stored_detail::write_one(w, x.feedforward, a);
        stored_detail::write_one(w, x.feedback, a);
        stored_detail::write_one(w, x.rc, a);
        if (x.has_trajectory) stored_detail::write_one(w, x.trajectory, a);
    }
    if (s.has_recorder) stored_detail::write_one(w, s.recorder);
    stored_detail::write_one(w, s.link);
    stored_detail::write_one(w, s.input_matrix);
    stored_detail::write_one(w, s.output_matrix);
    if (!w.ok()) return 0;
    if (!write_blob_header(kStoredParamsBlob, body.subspan(0, w.size()), out)) return 0;
    return kBlobHeaderBytes + w.size();
}

// True when `in` holds nothing: no bytes, or the all-ones word of erased flash.
inline bool storage_empty(std::span<const uint8_t> in) {
    if (in.empty()) return true;
    if (in.size() < 4) return false;
    return in[0] == 0xFF && in[1] == 0xFF && in[2] == 0xFF && in[3] == 0xFF;
}

// Reads the record at the start of `in` (trailing bytes, e.g. the rest of a
// flash sector, are ignored) into `out`, which holds a usable set only when
// the state is kApplied (the device still validates it) and is scratch
// otherwise. The device's firmware version must match the writer's.
inline RecordCheck decode_stored_params(std::span<const uint8_t> in, const char* firmware_version,
                                        StoredParams& out) {
    using namespace stored_detail;
    if (storage_empty(in)) return {StorageState::kEmpty, error("record", "nothing stored")};
    BlobHeader h;
    if (const Status s = read_blob_header(in, kStoredParamsBlob, h); !s.ok())
        return field_is(s, "version") ? other_firmware(s) : corrupt(s);
    if (h.length > kStoredParamsMaxBodyBytes) return corrupt(error("length", "longer than any parameter record"));
    std::span<const uint8_t> body;
    if (const Status s = blob_body(in, h, body); !s.ok()) return corrupt(s);

    link::Reader r(body);
    const uint8_t protocol = r.u8();
    std::array<char, link::kNameSize> version{};
    r.text(version.data(), version.size(), link::kNameSize);
    const float rate_Hz = r.f32();
    const uint8_t axis_count = r.u8();
    const uint8_t count = r.u8();
    if (!r.ok()) return corrupt(error("length", "body shorter than the record preamble"));
    if (protocol != link::kProtocolVersion)
        return other_firmware(error("protocol_version", "written by a firmware of another protocol version"));
    if (!same_text(version, firmware_version))
        return other_firmware(error("firmware_version", "written by another firmware version: save again"));

    if (axis_count < 1 || axis_count > kMaxStoredAxes) return corrupt(error("axis_count", "must be 1..3"));

    StoredParams& s = out;
    s = StoredParams{};
    s.protocol_version = protocol;
    s.firmware_version = version;
    s.loop_rate_Hz = rate_Hz;
    s.axis_count = axis_count;
    std::array<uint32_t, kMaxStoredAxes> seen{};  // bit per group id, per axis
    for (uint8_t i = 0; i < count; ++i) {
        const uint8_t id = r.u8();
        const uint8_t axis = r.u8();
        if (!r.ok()) break;
        if (id >= 32) return corrupt(error("groups", "group id out of range"));
        const auto g = static_cast<params::ParamGroup>(id);
        if (axis >= axis_count || (params::board_group(g) && axis != 0))
            return corrupt(error("groups", "a group's axis is beyond the axis count, or not 0 for a board group"));
        if ((seen[axis] & (1u << id)) != 0) return corrupt(error("groups", "group repeated"));
        seen[axis] |= 1u << id;
        const bool known = params::with_group(g, [&](auto tag) {
            using G = typename decltype(tag)::type;
            params::read_group(r, slot<G>(s, axis));
        });
        if (!known) return corrupt(error("groups", "unknown group id"));
        if (!r.ok() || r.bad_value()) return corrupt(error("groups", "a group does not match its layout"));
    }
    if (!r.ok()) return corrupt(error("groups", "a group does not match its layout"));
    if (r.remaining() != 0) return corrupt(error("groups", "bytes after the last group"));
    auto has = [&](uint8_t axis, params::ParamGroup g) { return (seen[axis] & (1u << static_cast<uint8_t>(g))) != 0; };
    for (uint8_t a = 0; a < axis_count; ++a) {
        for (const params::ParamGroup g : {params::ParamGroup::kLimits, params::ParamGroup::kFeedforward,
                                           params::ParamGroup::kFeedback, params::ParamGroup::kRepetitive})
            if (!has(a, g)) return corrupt(error("groups", "limits, feedforward, feedback and rc of every axis must be stored"));
        s.axes[a].has_trajectory = has(a, params::ParamGroup::kTrajectory);
    }
    for (const params::ParamGroup g : {params::ParamGroup::kLink, params::ParamGroup::kInputMatrix,
                                       params::ParamGroup::kOutputMatrix})
        if (!has(0, g)) return corrupt(error("groups", "link, input_matrix and output_matrix must be stored"));
    s.has_recorder = has(0, params::ParamGroup::kRecorder);
    return {StorageState::kApplied, ok_status()};
}

}  // namespace piezoloop::storage
