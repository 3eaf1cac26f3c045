#include "device_common.hpp"

#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <algorithm>
#include <stdexcept>

#include "link/params_json.hpp"
#include "link/usb_transport.hpp"
#include "options/option_checks.hpp"
#include "sim/multi_axis_loop.hpp"
#include "sim/scenario.hpp"

namespace piezoloop::cli {

const char* axis_name(int axis) {
    static constexpr const char* kNames[] = {"x", "y", "z"};
    return axis >= 0 && axis < 3 ? kNames[axis] : "?";
}

int resolve_axis(const std::string& axis, unsigned count, bool all_allowed) {
    std::string choices;
    for (unsigned i = 0; i < count && i < 3; ++i) choices += std::string(i == 0 ? "" : "|") + axis_name(static_cast<int>(i));
    if (all_allowed && count > 1) choices += "|all";
    if (axis.empty()) {
        if (count <= 1) return 0;
        throw std::invalid_argument("--axis: this board has " + std::to_string(count) + " axes: give --axis " + choices);
    }
    if (axis == "all" && all_allowed) return count <= 1 ? 0 : kAllAxes;
    for (unsigned i = 0; i < count && i < 3; ++i)
        if (axis == axis_name(static_cast<int>(i))) return static_cast<int>(i);
    throw std::invalid_argument("--axis: '" + axis + "' is not an axis of this board (" + std::to_string(count) +
                                " axes): " + choices);
}

std::string& device_address() {
    static std::string address;
    return address;
}

namespace {
volatile std::sig_atomic_t g_stop_requested = 0;
extern "C" void on_stop_signal(int) { g_stop_requested = 1; }
}  // namespace

StopSignals::StopSignals() {
    g_stop_requested = 0;
    int_ = std::signal(SIGINT, on_stop_signal);
    term_ = std::signal(SIGTERM, on_stop_signal);
}

StopSignals::~StopSignals() {
    std::signal(SIGINT, int_);
    std::signal(SIGTERM, term_);
}

bool StopSignals::requested() { return g_stop_requested != 0; }

hostlink::Client open_device(int timeout_ms) {
    const std::string& a = device_address();
    if (a.empty())
        throw std::invalid_argument(
            "no board given: put --device ADDR before the subcommand (or set PIEZOLOOP_DEVICE), e.g. "
            "`piezoloop --device tcp:127.0.0.1:4000 status`; `piezoloop devices` lists USB boards and how to start "
            "an emulated one");
    hostlink::Client::Options o;
    o.timeout = std::chrono::milliseconds(timeout_ms);
    hostlink::Client c(hostlink::open_transport(a), o);
    c.hello();
    return c;
}

bool measure_on_board(const std::string& scenario, const std::string& case_name, bool restart_stage) {
    const bool on_board = scenario.empty();
    if (on_board && device_address().empty())
        throw std::invalid_argument("--scenario: give a scenario (simulator) or --device ADDR before `measure` (board)");
    if (!on_board && !device_address().empty())
        throw std::invalid_argument("--scenario: measures the simulator; drop it to measure the board given by --device");
    if (on_board && !case_name.empty())
        throw std::invalid_argument("--case: only with --scenario (a board runs its own controller)");
    if (!on_board && restart_stage) throw std::invalid_argument("--restart-stage: only on a board (--device)");
    return on_board;
}

const sim::CaseSpec* measured_case(const sim::Scenario& s, const std::string& case_name, const std::string& sample,
                                   sim::CaseSpec& storage) {
    const sim::CaseSpec* c = case_name.empty() ? nullptr : &s.find_case(case_name);
    if (sample.empty()) return c;
    if (sample != "float" && sample != "q31") throw std::invalid_argument("--sample: must be float or q31");
    storage = c ? *c : sim::CaseSpec{};
    storage.sample = sample == "q31" ? sim::SampleType::kQ31 : sim::SampleType::kFloat;
    return &storage;
}

nlohmann::json usb_boards_json() {
    nlohmann::json out = nlohmann::json::array();
    for (const hostlink::UsbBoard& b : hostlink::list_usb_boards()) {
        char id[16];
        std::snprintf(id, sizeof id, "%04x:%04x", b.vid, b.pid);
        out.push_back({{"device", b.serial.empty() ? std::string("usb") : "usb:" + b.serial},
                       {"serial", b.serial},
                       {"product", b.product},
                       {"bus_port", b.bus_port},
                       {"vid_pid", id}});
    }
    return out;
}

CaseGroups case_groups(const PipelineParams& p) {
    return {params::limits_of(p), params::feedforward_of(p), params::feedback_of(p), params::rc_of(p)};
}

link::LimitsParams clip_to_hard_limits(const link::LimitsParams& l, const link::HelloReply& h,
                                       std::vector<std::string>& clipped) {
    link::LimitsParams out = l;
    auto note = [&](const char* field, float from, float to) {
        char t[200];
        std::snprintf(t, sizeof t, "limits.%s: %.9g -> %.9g (the board's hard limit)", field, static_cast<double>(from),
                      static_cast<double>(to));
        clipped.emplace_back(t);
    };
    if (l.limits.u_min_V < h.hard_u_min_V) {
        note("u_min_V", l.limits.u_min_V, h.hard_u_min_V);
        out.limits.u_min_V = h.hard_u_min_V;
    }
    if (l.limits.u_max_V > h.hard_u_max_V) {
        note("u_max_V", l.limits.u_max_V, h.hard_u_max_V);
        out.limits.u_max_V = h.hard_u_max_V;
    }
    if (l.limits.slew_V_per_s > h.hard_slew_max_V_per_s) {
        note("slew_V_per_s", l.limits.slew_V_per_s, h.hard_slew_max_V_per_s);
        out.limits.slew_V_per_s = h.hard_slew_max_V_per_s;
    }
    return out;
}

void check_wave_request(const WaveRequest& w) {
    if (w.trajectory != "triangle" && w.trajectory != "sine" && w.trajectory != "square" && w.trajectory != "raster")
        throw std::invalid_argument("--trajectory: must be triangle, sine, square or raster (got " + w.trajectory +
                                    "; steps and table waves are set with `set trajectory --json`)");
    options::require_in("--frequency-hz", w.frequency_Hz, 1e-4, 5e5, "Hz");
    if (w.amplitude_um == 0.0) throw std::invalid_argument("--amplitude-um: required, the peak-to-peak range (> 0)");
    options::require_in("--amplitude-um", w.amplitude_um, 1e-6, 1e3, "um");
    if (!w.offset.empty() && w.offset != "unipolar" && w.offset != "bipolar")
        throw std::invalid_argument("--offset: must be unipolar or bipolar (got " + w.offset + ")");
}

link::TrajectoryParams wave_params(const WaveRequest& w, double rate_Hz) {
    check_wave_request(w);
    std::string offset = w.offset;
    if (offset.empty() && !w.scenario.empty()) offset = sim::load_scenario(w.scenario).offset;
    if (offset.empty()) offset = "unipolar";
    sim::TrajectoryRequest t;
    t.waveform = hostlink::parse_waveform(w.trajectory);
    if (t.waveform == Waveform::kSteps || t.waveform == Waveform::kTable)
        throw std::invalid_argument("--trajectory: steps and table waves are set with `set trajectory --json`");
    t.frequency_Hz = w.frequency_Hz;
    t.range_um = w.amplitude_um;
    t.unipolar = offset == "unipolar";
    t.periods = 1;
    // sim::plan_run handles triangle and sine; the other periodic shapes use
    // the same amplitude / offset convention with phase 0.
    const Waveform requested = t.waveform;
    if (requested != Waveform::kSine) t.waveform = Waveform::kTriangle;
    const sim::RunOptions o = sim::plan_run(rate_Hz, t, 0, false);
    link::TrajectoryParams p;
    p.waveform = requested;
    p.amplitude_um = o.wave.amplitude_um;
    p.offset_um = o.wave.offset_um;
    p.frequency_Hz = o.wave.frequency_Hz;
    p.cycles = w.cycles;
    p.start_phase_cycles = requested == Waveform::kTriangle || requested == Waveform::kSine ? o.wave.start_phase_cycles
                                                                                             : 0.0f;
    p.return_fraction = o.wave.return_fraction;
    p.duty = o.wave.duty;
    return p;
}

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)), tty_(isatty(STDERR_FILENO) != 0) {}

void ProgressBar::update(double fraction) {
    if (!tty_) return;
    const int pct = static_cast<int>(std::floor(std::clamp(fraction, 0.0, 1.0) * 100.0));
    if (pct == last_) return;
    last_ = pct;
    const int width = 40, filled = pct * width / 100;
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(width, ' ');
    std::fprintf(stderr, "\r%s [%s] %3d%%", label_.c_str(), bar.c_str(), pct);
    std::fflush(stderr);
}

void ProgressBar::done() {
    if (tty_ && last_ >= 0) std::fprintf(stderr, "\n");
    last_ = -1;
}

namespace {

// One axis's controller groups, in an order the board accepts; their names
// are appended to `sent`.
void send_axis_groups(hostlink::Client& c, const PipelineParams& params, uint8_t axis, const link::HelloReply& h,
                      const std::string& prefix, nlohmann::json& sent, std::vector<std::string>& clipped,
                      const std::function<void(const std::string&)>& note) {
    CaseGroups g = case_groups(params);
    std::vector<std::string> clipped_here;
    g.limits = clip_to_hard_limits(g.limits, h, clipped_here);
    for (const std::string& m : clipped_here) {
        note("clipped: " + prefix + m);
        clipped.push_back(prefix + m);
    }
    c.set(g.limits, axis);
    sent.push_back(prefix + "limits");
    // RC needs feedback: switch it off before the feedback changes, on after.
    if (!g.rc.enabled) {
        c.set(g.rc, axis);
        sent.push_back(prefix + "rc");
    }
    // pi_series needs a feedback (its output feeds the inverse): set the
    // feedback first when going to it, the feedforward first otherwise (so
    // leaving pi_series never sees it without a feedback).
    const bool series = g.feedforward.kind == FeedforwardKind::kPiSeries;
    if (!series) {
        c.set(g.feedforward, axis);
        sent.push_back(prefix + "feedforward");
    }
    c.set(g.feedback, axis);
    sent.push_back(prefix + "feedback");
    if (series) {
        c.set(g.feedforward, axis);
        sent.push_back(prefix + "feedforward");
    }
    if (g.rc.enabled) {
        c.set(g.rc, axis);
        sent.push_back(prefix + "rc");
    }
}

// A case's matrix (empty: identity) as the board group's row-major n x n
// block (the layout's entries beyond the board's axes stay the identity's).
template <class G>
G matrix_group(const std::vector<std::vector<double>>& m, std::size_t n) {
    G g{};
    g.axis_count = static_cast<uint8_t>(n);
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j)
            g.gain[i * link::kMaxLinkAxes + j] = m.empty() ? (i == j ? 1.0f : 0.0f) : static_cast<float>(m[i][j]);
    return g;
}

}  // namespace

nlohmann::json send_scenario_case(hostlink::Client& c, const std::string& scenario, const std::string& case_name,
                                  double frequency_Hz, const std::function<void(const std::string&)>& note) {
    using nlohmann::json;
    const sim::Scenario s = sim::load_scenario(scenario);
    const sim::CaseSpec& cs = s.find_case(case_name);
    const link::HelloReply& h = c.info();
    if (cs.feedforward.kind == "dahl" && !(h.capabilities & link::cap::kDahl))
        throw std::invalid_argument("case " + cs.name + ": Dahl feedforward, which this board (" +
                                    std::string(h.board.data()) + ", Q31 pipeline) does not run");
    if (std::fabs(h.loop_rate_Hz - s.rate_Hz) > 1e-6 * s.rate_Hz)
        throw std::invalid_argument("scenario " + s.name + " is discretised at " + std::to_string(s.rate_Hz) +
                                    " Hz, the board runs at " + std::to_string(h.loop_rate_Hz) +
                                    " Hz (`piezoloop emulate --scenario` starts a board at the scenario's rate)");
    const std::size_t axes = s.multi_axis() ? s.axes.size() : 1;
    if (axes != h.axis_count)
        throw std::invalid_argument("scenario " + s.name + " has " + std::to_string(axes) + " axes, the board " +
                                    std::to_string(h.axis_count) +
                                    " (`piezoloop emulate --scenario` starts a board with the scenario's axes)");
    // Built for the board's sample type, as `piezoloop sim --sample` does:
    // a Q31 board gets the fixed-point scaling of the feedback sections.
    sim::CaseSpec cb = cs;
    const bool board_q31 = h.sample_format == link::SampleFormat::kQ31;
    if ((cb.sample == sim::SampleType::kQ31) != board_q31)
        note("note: case " + cs.name + " is simulated with " + sim::to_string(cb.sample) +
             " samples; built for this board's " + (board_q31 ? "q31" : "float") +
             " (compare with `piezoloop sim --sample " + (board_q31 ? "q31" : "float") + "`)");
    cb.sample = board_q31 ? sim::SampleType::kQ31 : sim::SampleType::kFloat;
    sim::BuildOptions bo;
    bo.reference_frequency_Hz = frequency_Hz;
    bo.check_realisation = false;
    sim::MultiAxisModel m;
    try {
        m = sim::build_multi_axis_case(s, cb, bo);
    } catch (const std::exception& e) {
        std::string msg = e.what();
        if (msg.find("periodic reference") != std::string::npos) msg += " (give --frequency-hz)";
        throw std::invalid_argument(msg);
    }
    if (c.status().armed)
        throw std::invalid_argument("the loop is armed: limits and block kinds change only while disarmed "
                                    "(`piezoloop --device " + c.address() + " disarm` first)");
    json sent = json::array();
    std::vector<std::string> clipped;
    for (std::size_t i = 0; i < axes; ++i)
        send_axis_groups(c, m.axes[i].model.params, static_cast<uint8_t>(i), h, axes > 1 ? m.names[i] + "." : "",
                         sent, clipped, note);
    if (axes > 1) {
        c.set(matrix_group<link::OutputMatrixParams>(m.output_matrix, axes));
        sent.push_back("output_matrix");
        link::InputMatrixParams in = matrix_group<link::InputMatrixParams>(m.input_matrix, axes);
        for (std::size_t i = 0; i < axes && !m.input_offset_um.empty(); ++i)
            in.offset_um[i] = static_cast<float>(m.input_offset_um[i]);
        c.set(in);
        sent.push_back("input_matrix");
    }
    json out = {{"device", c.address()}, {"scenario", s.name}, {"case", cs.name}, {"label", cs.label},
                {"sent", sent},          {"clipped", clipped}};
    for (const sim::BuiltCase& b : m.axes)
        for (const std::string& n : b.notes) out["notes"].push_back(n);
    return out;
}

}  // namespace piezoloop::cli
