// Writes the seed corpus of fuzz_link_decoder: valid frames of every request
// type (and a few device-to-host ones, which the device must refuse), short
// realistic sessions, and broken frames (bad CRC, truncated, oversize,
// unknown type, wrong version, malformed bodies, NaN parameters, garbage).
// Deterministic; run as `make_link_corpus <dir>` (tests check it is current).
// Each file starts with the chunk-size byte the target reads first.
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "piezoloop/link/messages.hpp"
#include "piezoloop/reference_stage.hpp"

using namespace piezoloop;
using namespace piezoloop::link;

namespace {

std::string g_dir;
uint16_t g_seq = 1;

template <class M>
std::vector<uint8_t> frame(const M& m, uint8_t version = kProtocolVersion) {
    std::vector<uint8_t> f(kMaxFrameSize);
    f.resize(encode_message(m, g_seq++, f, version));
    return f;
}

void write(const std::string& name, const std::vector<uint8_t>& bytes, uint8_t chunk = 0x20) {
    std::ofstream out(g_dir + "/" + name, std::ios::binary);
    out.put(static_cast<char>(chunk));
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

std::vector<uint8_t> cat(std::initializer_list<std::vector<uint8_t>> parts) {
    std::vector<uint8_t> v;
    for (const auto& p : parts) v.insert(v.end(), p.begin(), p.end());
    return v;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s <corpus dir>\n", argv[0]);
        return 2;
    }
    g_dir = argv[1];
    const PipelineParams p = reference::params(true, true, true);
    const FeedforwardParams ff{p.feedforward, p.pi, p.dahl};
    const FeedbackParams fb{p.feedback, p.sos_count, p.sos, p.pid};
    const RepetitiveParams rc{true, p.rc};
    const LimitsParams lim{p.limits};
    TrajectoryParams wave;
    wave.waveform = Waveform::kTriangle;
    wave.amplitude_um = 12.0f;
    wave.frequency_Hz = 10.0f;
    TrajectoryParams table = wave;
    table.waveform = Waveform::kTable;
    table.table_count = 4;
    table.table = {-1.0f, 0.0f, 1.0f, 0.0f};
    RecorderParams rec;
    rec.channel_count = 4;
    rec.channels = {0, 1, 2, 3};
    rec.decimation = 2;
    SetpointBlock sp;
    sp.count = 50;
    for (int i = 0; i < 50; ++i) sp.setpoint_um[i] = 0.1f * static_cast<float>(i);

    // One valid frame per request type.
    write("hello", frame(Hello{}));
    write("status", frame(GetStatus{}));
    for (int g = 1; g <= params::kGroupCount; ++g)
        write("get_" + std::to_string(g), frame(GetParams{static_cast<ParamGroup>(g)}));
    write("set_ff", frame(SetParams<FeedforwardParams>{ff}));
    write("set_fb", frame(SetParams<FeedbackParams>{fb}));
    write("set_rc", frame(SetParams<RepetitiveParams>{rc}));
    write("set_limits", frame(SetParams<LimitsParams>{lim}));
    write("set_wave", frame(SetParams<TrajectoryParams>{wave}));
    write("set_table", frame(SetParams<TrajectoryParams>{table}));
    write("set_recorder", frame(SetParams<RecorderParams>{rec}));
    InputMatrixParams in;
    in.offset_um[0] = 0.5f;
    write("set_input_matrix", frame(SetParams<InputMatrixParams>{in}));
    OutputMatrixParams out;
    out.axis_count = 3;
    out.gain[1] = -0.04f;
    out.gain[3] = 0.02f;
    write("set_output_matrix", frame(SetParams<OutputMatrixParams>{out}));
    write("arm", frame(Arm{}));
    write("disarm", frame(Disarm{}));
    write("clear_trip", frame(ClearTrip{}));
    write("start_wave", frame(StartWave{}));
    StartWave wave_z{StartWave::kArmLoop};
    wave_z.axis = 2;
    write("start_wave_axis_2", frame(wave_z));
    SetParams<LimitsParams> lim_y{lim};
    lim_y.axis = 1;
    write("set_limits_axis_1", frame(lim_y));
    write("get_limits_axis_3", frame(GetParams{ParamGroup::kLimits, 3}));
    StreamStart stream_y{20};
    stream_y.axis = 1;
    write("stream_start_axis_1", frame(stream_y));
    write("stop_wave", frame(StopWave{}));
    write("stream_start", frame(StreamStart{20}));
    write("setpoints", frame(sp));
    write("stream_stop", frame(StreamStop{true}));
    write("recorder_arm", frame(RecorderArm{}));
    write("recorder_stop", frame(RecorderStop{}));
    StartExcitation exc;
    exc.flags = StartExcitation::kArmLoop | StartExcitation::kArmRecorder;
    exc.config.period_samples = 64;
    exc.config.first_bin = 1;
    exc.config.last_bin = 20;
    exc.config.amplitude = 0.5f;
    exc.config.offset = 1.0f;
    exc.config.periods = 2;
    write("start_excitation", frame(exc));
    write("stop_excitation", frame(StopExcitation{}));
    StartScan scan;
    scan.flags = StartWave::kArmLoop | StartWave::kArmRecorder;
    scan.config.pixels_per_line = 8;
    scan.config.lines_per_frame = 4;
    write("start_scan", frame(scan));
    scan.config.pattern = ScanPattern::kSpiral;
    write("start_scan_spiral", frame(scan));
    write("save", frame(Save{}));
    write("load", frame(Load{}));
    write("forget", frame(Forget{}));
    // Device-to-host types sent to the device: unknown there.
    write("ack", frame(Ack{1}));
    write("log_block", frame(LogBlock{}));

    // Sessions.
    write("session_wave", cat({frame(SetParams<LimitsParams>{lim}), frame(SetParams<RecorderParams>{rec}),
                               frame(RecorderArm{}), frame(SetParams<TrajectoryParams>{wave}), frame(Arm{}),
                               frame(StartWave{}), frame(GetStatus{}), frame(StopWave{}), frame(Disarm{})}), 0x07);
    sp.block_seq = 0;
    auto b0 = frame(sp);
    sp.block_seq = 1;
    auto b1 = frame(sp);
    write("session_stream", cat({frame(Arm{}), frame(StreamStart{60}), b0, b1, frame(GetStatus{}), frame(StreamStop{false})}), 0x40);
    write("session_storage", cat({frame(SetParams<LimitsParams>{lim}), frame(SetParams<TrajectoryParams>{wave}),
                                  frame(SetParams<RecorderParams>{rec}), frame(Save{}), frame(Forget{}), frame(Load{}),
                                  frame(Save{}), frame(SetParams<FeedbackParams>{fb}), frame(Load{}), frame(Arm{}),
                                  frame(Save{}), frame(GetStatus{})}), 0x30);
    RecorderParams rec_axes = rec;
    rec_axes.axes = {0, 1, 2, 0, 0, 0, 0, 0};
    rec_axes.trigger_axis = 1;
    StopWave stop_z;
    stop_z.axis = 2;
    write("session_axes", cat({frame(SetParams<LimitsParams>{lim}), frame(lim_y), frame(SetParams<RecorderParams>{rec_axes}),
                               frame(SetParams<OutputMatrixParams>{out}), frame(wave_z), frame(GetStatus{}),
                               frame(SetParams<InputMatrixParams>{in}), frame(stop_z), frame(Disarm{})}), 0x09);
    write("session_armed_limits", cat({frame(Arm{}), frame(SetParams<LimitsParams>{LimitsParams{{-5.0f, 5.0f, 1.0e5f, 0.0f}}}),
                                       frame(SetParams<FeedbackParams>{FeedbackParams{FeedbackKind::kPid, 0, {}, {}}})}), 0x01);

    // Broken frames.
    auto bad_crc = frame(Arm{});
    bad_crc[2] = static_cast<uint8_t>(bad_crc[2] ^ 0x10 ? bad_crc[2] ^ 0x10 : 0x33);
    write("bad_crc", bad_crc);
    auto truncated = frame(SetParams<FeedbackParams>{fb});
    truncated.erase(truncated.begin() + 40, truncated.end() - 1);
    write("truncated", truncated);
    write("oversize", std::vector<uint8_t>(1200, 0x41), 0x60);
    std::vector<uint8_t> unk(kMaxFrameSize);
    unk.resize(encode_frame(0x42, kProtocolVersion, 3, {}, unk));
    write("unknown_type", unk);
    write("bad_version", frame(GetStatus{}, 9));
    std::vector<uint8_t> bad_body(kMaxFrameSize);
    const std::vector<uint8_t> body{static_cast<uint8_t>(ParamGroup::kLimits), 1, 2};
    bad_body.resize(encode_frame(static_cast<uint8_t>(MsgType::kSetParams), kProtocolVersion, 4, body, bad_body));
    write("short_body", bad_body);
    LimitsParams nan_lim = lim;
    nan_lim.limits.u_max_V = std::numeric_limits<float>::quiet_NaN();
    write("nan_limits", frame(SetParams<LimitsParams>{nan_lim}));
    FeedforwardParams nan_ff = ff;
    nan_ff.pi.weights[2] = std::numeric_limits<float>::infinity();
    write("inf_pi_weight", frame(SetParams<FeedforwardParams>{nan_ff}));
    // A modified PI compensator: the input map's dead zones (valid), and one
    // whose map falls (slope 1 + q_1 < 0).
    FeedforwardParams zones = ff;
    zones.kind = FeedforwardKind::kPiCompensator;
    zones.pi.dead_zones = 2;
    zones.pi.dead_zone_thresholds = {-5.0f, 5.0f};
    zones.pi.dead_zone_weights = {0.5f, -0.25f};
    write("pi_dead_zones", frame(SetParams<FeedforwardParams>{zones}));
    zones.pi.dead_zone_weights[0] = -1.5f;
    write("pi_dead_zones_falling", frame(SetParams<FeedforwardParams>{zones}));
    std::vector<uint8_t> garbage;
    uint32_t x = 12345;
    for (int i = 0; i < 300; ++i) {
        x = x * 1103515245u + 12345u;
        garbage.push_back(static_cast<uint8_t>(x >> 16));
    }
    write("garbage_then_hello", cat({garbage, frame(Hello{})}), 0x11);
    return 0;
}
