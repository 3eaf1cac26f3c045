#include "device_common.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <stdexcept>

#include "link/params_json.hpp"

namespace piezoloop::cli {

std::string& device_address() {
    static std::string address;
    return address;
}

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

link::TrajectoryParams wave_params(const WaveRequest& w, double rate_Hz) {
    if (!(w.amplitude_um > 0.0)) throw std::invalid_argument("--amplitude-um: required, the peak-to-peak range (> 0)");
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

}  // namespace piezoloop::cli
