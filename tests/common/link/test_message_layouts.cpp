// The messages' wire layouts (common/piezoloop/link/messages.hpp), each
// message filled with a distinct value in every field: the encoded bodies
// are byte for byte tests/golden/link_message_bodies.txt (captured from the
// field-by-field codec these layouts replaced, protocol version 4, and
// extended by the fields of version 5: the axes), every body decodes back to
// the message, and the declared layout sizes are the encoded ones.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "piezoloop/link/messages.hpp"

using namespace piezoloop;
using namespace piezoloop::link;

namespace {

HelloReply hello() {
    HelloReply m;
    m.protocol_version = 4;
    set_text(m.board, "qemu-m7");
    set_text(m.firmware_version, "1.2.3-rc4");
    set_text(m.serial, "0123456789ABCDEF0123456789ABCD");
    m.loop_rate_Hz = 100000.5f;
    m.capabilities = 0x1FEu;
    m.sample_format = SampleFormat::kQ31;
    m.hard_u_min_V = -1.25f;
    m.hard_u_max_V = 11.5f;
    m.hard_slew_max_V_per_s = 2.5e5f;
    m.position_full_scale_um = 50.5f;
    m.voltage_full_scale_V = 16.25f;
    m.max_payload = 512;
    m.setpoint_capacity = 1023;
    m.recorder_channels = 3;
    m.recorder_capacity = 0x12345u;
    m.max_sos_sections = 5;
    m.max_play_operators = 17;
    m.max_wave_table = 97;
    m.rc_capacity = 0x23456u;
    m.excitation_capacity = 0x34567u;
    m.axis_count = 2;
    m.axis_hard_u_min_V = {-1.25f, -2.5f, 0.0f};
    m.axis_hard_u_max_V = {11.5f, 12.5f, 0.0f};
    m.axis_hard_slew_max_V_per_s = {2.5e5f, 3.5e5f, 0.0f};
    m.axis_position_full_scale_um = {50.5f, 60.5f, 0.0f};
    m.axis_voltage_full_scale_V = {16.25f, 17.25f, 0.0f};
    return m;
}

StatusReply status() {
    StatusReply m;
    m.armed = true;
    m.tripped = false;
    m.trip_reason = static_cast<TripReason>(4);
    m.wave_running = true;
    m.streaming = false;
    m.swap_pending = true;
    m.recorder_state = static_cast<RecorderState>(2);
    m.faults = 0x80000021u;
    m.tick_count = 0x01020304u;
    m.swaps = 7;
    m.tick = {11, 12, 13, 14.5f, 2.5e7f, 0x100u};
    m.setpoint_underruns = 21;
    m.setpoint_free = 0x0A0B;
    m.setpoint_next_seq = 23;
    m.recorder_overruns = 24;
    m.log_blocks = 25;
    m.link = {31, 32, 33, 34, 35, 36, 37, 38, 39, 40};
    m.r_um = -1.5f;
    m.y_um = 2.25f;
    m.u_V = 3.125f;
    m.excitation_running = true;
    m.excitation_ticks = 0x00ABCDEFu;
    m.excitation_clipped = 41;
    m.storage = StorageState::kRejected;
    set_text(m.storage_group, "feedforward");
    set_text(m.storage_field, "pi.weights");
    m.storage_index = -2;
    set_text(m.storage_message, "must be finite");
    m.axis_count = 2;
    m.axis_armed = {true, false, false};
    m.axis_tripped = {false, true, false};
    m.axis_trip_reason = {0, 3, 0};
    m.axis_wave_running = {true, false, false};
    m.axis_excitation_running = {false, true, false};
    m.axis_swaps = {7, 8, 0};
    m.axis_excitation_ticks = {0x00ABCDEFu, 42, 0};
    m.axis_excitation_clipped = {41, 43, 0};
    m.axis_r_um = {-1.5f, 0.5f, 0.0f};
    m.axis_y_um = {2.25f, 0.75f, 0.0f};
    m.axis_u_V = {3.125f, 4.0f, 0.0f};
    m.channel_u_V = {3.0f, 4.25f, 0.0f};
    m.channel_clamped = {44, 45, 0};
    m.channel_slew_limited = {46, 47, 0};
    m.scan_state = 3;
    m.scan_approach_ticks = 0x00010203u;
    m.scan_ticks = 0x04050607u;
    m.scan_frames_completed = 9;
    return m;
}

StartScan scan() {
    StartScan m;
    m.flags = 0x0B;
    ScanConfig& c = m.config;
    c.pattern = ScanPattern::kCycloid;
    c.centre_x_um = 50.5f;
    c.centre_y_um = -25.25f;
    c.hold_z_um = 7.5f;
    c.rotation_deg = -30.0f;
    c.frames = 0x01020304u;
    c.pixels_per_line = 256;
    c.size_x_um = 20.0f;
    c.size_y_um = 10.0f;
    c.lines_per_frame = 0x0506u;
    c.line_rate_Hz = 75.0f;
    c.retrace_speed_factor = 4.0f;
    c.overscan_fraction = 0.125f;
    c.turnaround_s = 0.0025f;
    c.slow_axis = SlowAxis::kRamp;
    c.bidirectional = true;
    c.fast_axis = FastAxis::kSine;
    c.spiral_mode = SpiralMode::kConstantLinearVelocity;
    c.radius_um = 6.0f;
    c.turns = 0x0708u;
    c.turn_rate_Hz = 250.0f;
    c.linear_speed_um_s = 1500.0f;
    c.frequency_x_Hz = 23.0f;
    c.frequency_y_Hz = 19.0f;
    c.phase_y_deg = 90.0f;
    c.turns_per_line = 0x090Au;
    return m;
}

SetpointAck setpoint_ack() { return {0x01020304u, 0x0506, 0x0708, 0x090A0B0Cu, 0x0D0E0F10u}; }

SetpointBlock setpoints() {
    SetpointBlock m;
    m.block_seq = 0x11223344u;
    m.count = 3;
    m.setpoint_um[0] = 1.0f;
    m.setpoint_um[1] = -2.5f;
    m.setpoint_um[2] = 1e6f;
    return m;
}

ErrorReply error() {
    Status s;
    s.group = "limits";
    s.field = "u_max_V";
    s.index = 3;
    s.message = "must be finite and <= the hard limit u_max_V";
    return make_error(0x04, ErrorCode::kInvalidParam, s);
}

StartExcitation excitation() {
    StartExcitation m;
    m.axis = 2;
    m.flags = 0x0B;
    ExcitationConfig& c = m.config;
    c.signal = static_cast<ExcitationSignal>(2);
    c.point = ExcitationPoint::kReference;
    c.amplitude = -0.75f;
    c.offset = 4.5f;
    c.period_samples = 0x00010203u;
    c.first_bin = 5;
    c.last_bin = 0x0706u;
    c.f1_Hz = 1.5f;
    c.f2_Hz = 2500.0f;
    c.prbs_order = 17;
    c.prbs_hold = 0x0909u;
    c.periods = 0x0A0B0C0Du;
    return m;
}

LogBlock log_block() {
    LogBlock m;
    m.block_seq = 9;
    m.first_tick = 0xFFFFFFF0u;
    m.tick_stride = 2;
    m.recorder_overruns = 3;
    m.channel_count = 2;
    m.format = SampleFormat::kQ31;
    m.frame_count = 3;
    m.flags = LogBlock::kFlagLast;
    m.channels = {1, 3, 0, 0, 0, 0, 0, 0};
    for (std::size_t i = 0; i < 6; ++i) m.samples[i] = 0x80000000u + static_cast<uint32_t>(i);
    return m;
}

template <class M>
std::string body_hex(const M& m) {
    std::array<uint8_t, kMaxPayload> buf{};
    Writer w{std::span<uint8_t>(buf)};
    m.write(w);
    EXPECT_TRUE(w.ok());
    std::string out;
    for (std::size_t i = 0; i < w.size(); ++i) {
        char b[3];
        std::snprintf(b, sizeof b, "%02x", buf[i]);
        out += b;
    }
    return out;
}

std::map<std::string, std::string> bodies() {
    return {{"HelloReply", body_hex(hello())},           {"StatusReply", body_hex(status())},
            {"SetpointAck", body_hex(setpoint_ack())},   {"Setpoints", body_hex(setpoints())},
            {"Error", body_hex(error())},                {"StartExcitation", body_hex(excitation())},
            {"LogBlock", body_hex(log_block())},         {"StartScan", body_hex(scan())}};
}

}  // namespace

TEST(LinkMessageLayouts, BodiesAreTheGoldenOnes) {
    std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/link_message_bodies.txt");
    ASSERT_TRUE(f.good());
    std::map<std::string, std::string> golden;
    std::string line;
    while (std::getline(f, line)) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream l(line);
        std::string name, hex;
        l >> name >> hex;
        golden[name] = hex;
    }
    const std::map<std::string, std::string> now = bodies();
    EXPECT_EQ(golden.size(), now.size());
    for (const auto& [name, hex] : now) EXPECT_EQ(golden[name], hex) << name;
}
