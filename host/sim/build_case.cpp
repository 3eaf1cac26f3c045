#include "sim/build_case.hpp"

#include <cmath>
#include <complex>
#include <sstream>
#include <stdexcept>

#include "format/number.hpp"
#include "ident/dead_zone_map.hpp"
#include "lti/realisation.hpp"
#include "lti/sos.hpp"
#include "piezoloop/pi_inverse.hpp"
#include "sim/design_bridge.hpp"
#include "status_text.hpp"
#include "sim/f32.hpp"

namespace piezoloop::sim {

namespace {

[[noreturn]] void fail(const std::string& path, const Status& s) {
    std::string text = path;
    if (!text.empty()) text += ".";
    text += describe(s);
    throw ScenarioError(text);
}

PlantConfig hysteresis_config(const HysteresisSpec& h) {
    PlantConfig p{};
    p.hysteresis = h.core;
    p.pi = h.pi;
    p.dahl = h.dahl;
    p.linear_gain_um_per_V = f32(h.gain_um_per_V);
    p.output_map = h.output_map;
    return p;
}

// The toolkit's realisation check of the controller as the core will run it.
std::string realisation_note(const design::Zpk& discrete, const PipelineParams& p, SampleType sample,
                             SignalScale in, SignalScale out) {
    design::RealisationOptions ro;
    ro.format = sample == SampleType::kQ31 ? design::SampleFormat::kQ31 : design::SampleFormat::kFloat;
    ro.in_full_scale = in.full_scale;
    ro.out_full_scale = out.full_scale;
    const std::vector<SosSection> sos(p.sos.begin(), p.sos.begin() + p.sos_count);
    const design::RealisationReport r = design::check_realisation(discrete, sos, ro);
    std::string text = std::string(design::sample_format_name(ro.format)) + " realisation of the controller (lti/realisation): ";
    if (!r.configured) return text + "rejected: " + r.configure_error;
    text += "response within " + format::significant(r.max_error_db, 2) + " dB / " + format::significant(r.max_phase_error_deg, 2) +
            " deg of the design (worst at " + format::significant(r.worst_f_hz, 3) + " Hz), poles moved by up to " +
            format::significant(100.0 * r.max_relative_pole_shift, 2) + " % of their distance to the unit circle; sections:";
    for (size_t i = 0; i < r.section_forms.size(); ++i) text += (i ? "; " : " ") + r.section_forms[i];
    text += r.fit ? " (fit)." : " - UNFIT:";
    if (!r.fit)
        for (const std::string& w : r.warnings) text += " " + w;
    return text;
}

// The same compensator on its input x itself (input_gain 1): the play
// operators are positively homogeneous, k p0 x + sum k w play_{r/k}(x) =
// p0 (k x) + sum w play_r(k x) for k > 0, so the thresholds move to the
// input's unit (µm). In Q31 the input then stays within the position full
// scale, which k x would not (Shan2012: k = 1 / 0.29). Used for the series
// placement; the feedforward placement keeps the affine form (its float
// results unchanged).
PiModel on_unit_input(const PiModel& c) {
    if (!(c.input_gain > 0.0f) || c.input_offset != 0.0f || c.input_gain == 1.0f) return c;
    const double k = c.input_gain;
    PiModel u = c;
    u.input_gain = 1.0f;
    u.p0 = f32(c.p0 * k);
    for (int j = 0; j < c.count; ++j) {
        const size_t i = static_cast<size_t>(j);
        u.thresholds[i] = f32(c.thresholds[i] / k);
        u.weights[i] = f32(c.weights[i] * k);
    }
    return u;
}

}  // namespace

PiModel inverse_compensator(const HysteresisSpec& h, double amplifier_gain, std::string& note) {
    if (h.core == HysteresisKind::kDahl) throw ScenarioError(h.path + ": pi_inverse needs a PI (or linear) hysteresis");
    PiModel inv{};
    if (h.core == HysteresisKind::kNone) {
        inv.p0 = f32(1.0);
    } else if (const Status s = invert_pi(h.plain, inv); !s.ok()) {
        fail(h.path, s);
    }
    // x = out * plain(a v + b), v = G u  =>  u = (plain^-1(x / out) - b) / (a G)
    const double a = h.in_gain, g = amplifier_gain;
    PiModel c = inv;
    c.input_gain = f32(1.0 / h.out_gain);
    c.input_offset = 0.0f;
    c.p0 = f32(inv.p0 / (a * g));
    for (int j = 0; j < c.count; ++j) c.weights[static_cast<size_t>(j)] = f32(inv.weights[static_cast<size_t>(j)] / (a * g));
    // S's inverse on the reference first (the modified PI's compensator).
    if (h.output_map.count > 0) design::set_input_map(design::inverse(design::dead_zone_map(h.output_map)), c);
    if (h.in_offset != 0.0)
        note = "the inverse omits the model's constant input offset (" + format::significant(-h.in_offset / (a * g), 4) +
               " V of command); the feedback's integral action takes it up";
    return c;
}

StageConfig float_stage_config(const PlantSpec& p, const HysteresisSpec& h, double rate_Hz, int* sections) {
    StageConfig st{};
    st.rate_Hz = f32(rate_Hz);
    st.dac = p.dac;
    st.amplifier = p.amplifier;
    st.sensor = p.sensor;
    st.adc = p.adc;
    st.plant = hysteresis_config(h);
    st.plant.creep = p.creep;
    st.plant.drift_um_per_s = p.drift_um_per_s;
    if (p.dynamics) {
        const std::string where = p.dynamics->path.empty() ? "plant.dynamics" : p.dynamics->path;
        const bool advance = p.discretisation != "tustin";
        const std::vector<SosSection> sos =
            discretise_sos(p.dynamics->zpk, rate_Hz, p.discretisation, 0.0, advance, where, kMaxPlantSections);
        if (sos.size() > static_cast<size_t>(kMaxPlantSections))
            throw ScenarioError(where + ": at most " + std::to_string(kMaxPlantSections) +
                                " biquad sections (order 12) in the float stage");
        st.plant.sections = static_cast<int>(sos.size());
        for (size_t i = 0; i < sos.size(); ++i) st.plant.dynamics[i] = sos[i];
        if (sections) *sections = static_cast<int>(sos.size());
    }
    return st;
}

void build_stage(const Scenario& s, const CaseSpec* c, int substeps, LoopModel& out, int* sections) {
    // The loop, its logs and the emulated board are one axis's; a stage of
    // coupled axes (sim/coupled_stage_build.hpp) is not silently cut to one.
    require_single_axis(s, "this command");
    const PlantSpec& p = s.plant;
    const HysteresisSpec& h = c && c->plant_hysteresis ? *c->plant_hysteresis : p.hysteresis;
    const StageConfig st = float_stage_config(p, h, s.rate_Hz, sections);
    DoubleStageConfig d{};
    d.rate_Hz = s.rate_Hz;
    d.substeps = substeps;
    d.dac = p.dac;
    d.amplifier = p.amplifier;
    d.hysteresis = h.core;
    d.pi = h.pi;
    d.dahl = h.dahl;
    d.linear_gain_um_per_V = h.gain_um_per_V;
    d.output_map = h.output_map;
    d.sensor = p.sensor;
    d.adc = p.adc;
    d.creep = p.creep;
    d.drift_um_per_s = p.drift_um_per_s;
    if (p.dynamics) d.dynamics = state_space(p.dynamics->zpk);
    StageModel probe;
    if (const Status e = probe.configure(st); !e.ok()) fail("plant", e);
    out.stage = st;
    out.stage_double = d;
}

const DahlIdentification& DahlCache::get(const Scenario& s, const CaseSpec& c, int substeps) {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::string key = s.name + "/" + c.name;
    if (const auto it = done_.find(key); it != done_.end()) return it->second;
    const DahlIdentifySpec& id = *c.feedforward.identify;
    // Open loop on the case's stage: the command is a triangle from 0 V to
    // A / G (A peak-to-peak on the piezo), the reading is the measured
    // displacement. The core's trajectory generator makes the triangle, a
    // unit gain "feedforward" passes it to the DAC (r read as volts).
    LoopModel m;
    build_stage(s, &c, substeps, m);
    m.setup = s.setup;
    m.setup.position = SignalScale{1.0f};
    m.params = PipelineParams{};
    m.params.feedforward = FeedforwardKind::kPiCompensator;
    m.params.pi = PiModel{};
    m.params.pi.p0 = 1.0f;
    m.params.limits = s.limits;
    m.sample = SampleType::kFloat;
    std::vector<double> u, y;
    const double g = s.plant.amplifier.gain;
    const uint64_t period = static_cast<uint64_t>(std::llround(s.rate_Hz / id.frequency_Hz));
    for (const double a : id.amplitudes_V) {
        RunOptions o;
        o.wave.waveform = Waveform::kTriangle;
        o.wave.frequency_Hz = f32(id.frequency_Hz);
        o.wave.amplitude_um = f32(0.5 * a / g);
        o.wave.offset_um = f32(0.5 * a / g);
        o.ticks = period * static_cast<uint64_t>(id.cycles);
        o.window_start = 0;
        o.log_start = 0;
        o.log_every = 1;
        const RunResult r = run_loop(m, o);
        // u_k is applied during tick k and read back at tick k + 1: pair
        // (u_k, y_{k+1}), every `decimate`-th tick.
        for (size_t k = 0; k + 1 < r.log.u_V.size(); k += static_cast<size_t>(id.decimate)) {
            u.push_back(r.log.u_V[k]);
            y.push_back(r.log.y_um[k + 1]);
        }
    }
    design::DahlFitOptions fo;
    fo.gamma_a = id.gamma_a;
    fo.input_name = "u";
    fo.output_name = "y";
    DahlIdentification d;
    try {
        d.fit = design::fit_dahl(u, y, fo);
    } catch (const std::exception& e) {
        throw ScenarioError(c.feedforward.path + ".identify: the Dahl fit refused the loops: " + e.what());
    }
    d.params = d.fit.params_float;
    d.samples = u.size();
    std::string amps;
    for (const double a : id.amplitudes_V) amps += (amps.empty() ? "" : ", ") + format::significant(a, 4);
    d.data = format::significant(id.frequency_Hz, 4) + " Hz triangles of " + amps + " V peak-to-peak on the piezo, " +
             std::to_string(id.cycles) + " cycles each from rest, every " + std::to_string(id.decimate) +
             "th tick (" + std::to_string(u.size()) + " samples of command u and measured y)";
    return done_.emplace(key, d).first->second;
}

BuiltCase build_case(const Scenario& s, const CaseSpec& c, const BuildOptions& o, DahlCache* cache) {
    BuiltCase b;
    LoopModel& m = b.model;
    build_stage(s, &c, o.substeps, m, &b.plant_sections);
    m.setup = s.setup;
    m.sample = c.sample;
    PipelineParams& p = m.params;
    p = PipelineParams{};
    p.limits = s.limits;
    const double g = s.plant.amplifier.gain;

    // Feedforward.
    const FeedforwardSpec& ff = c.feedforward;
    if (ff.kind == "gain") {
        p.feedforward = FeedforwardKind::kPiCompensator;
        p.pi = PiModel{};
        p.pi.p0 = f32(ff.V_per_um);
    } else if (ff.kind == "pi_inverse") {
        const HysteresisSpec& h = ff.of == "plant" && c.plant_hysteresis ? *c.plant_hysteresis : s.plant.hysteresis;
        std::string note;
        const PiModel inv = inverse_compensator(h, g, note);
        if (!note.empty()) b.notes.push_back(note);
        // Series (Shan2012): u = limits(P^-1(r + u_fb)), the core's
        // kPiSeries; otherwise u = limits(P^-1(r) + u_fb).
        p.feedforward = ff.placement == "series" ? FeedforwardKind::kPiSeries : FeedforwardKind::kPiCompensator;
        p.pi = ff.placement == "series" ? on_unit_input(inv) : inv;
        if (ff.placement == "series")
            b.notes.push_back("inverse in series after the controller (Shan2012's structure, the core's pi_series): "
                              "u = limits(P^-1(r + u_fb)), the feedback's output in um (its published volts at " +
                              format::significant(s.command_um_per_V(), 4) + " um/V); the limits stay last, in volts");
    } else if (ff.kind == "pi_compensator") {
        p.feedforward = ff.placement == "series" ? FeedforwardKind::kPiSeries : FeedforwardKind::kPiCompensator;
        p.pi = ff.placement == "series" ? on_unit_input(ff.pi) : ff.pi;
    } else if (ff.kind == "dahl") {
        p.feedforward = FeedforwardKind::kDahl;
        if (ff.dahl) {
            p.dahl = *ff.dahl;
        } else {
            DahlCache local;
            DahlCache& dc = cache ? *cache : local;
            const DahlIdentification& d = dc.get(s, c, o.substeps);
            p.dahl = d.params;
            b.dahl = d;
        }
    }

    // Feedback, in the controller's error unit: gains scaled to µm.
    const FeedbackSpec& fb = c.feedback;
    // In series placement the feedback's output is a displacement
    // correction: the published controller's volts become µm at the mean
    // slope (and its Q31 output is scaled by the position full scale).
    const bool series = p.feedforward == FeedforwardKind::kPiSeries;
    // A compensator given in series takes the feedback's output in µm as it is.
    const double out = series && ff.kind == "pi_inverse" ? s.command_um_per_V() : 1.0;
    const SignalScale fb_out = series ? m.setup.position : m.setup.voltage;
    const double k = fb.error_per_um * out;
    if (fb.kind == "pid") {
        p.feedback = FeedbackKind::kPid;
        p.pid = fb.pid;
        p.pid.kp = f32(fb.pid.kp * k);
        p.pid.ki_per_s = f32(fb.pid.ki_per_s * k);
        p.pid.kd_s = f32(fb.pid.kd_s * k);
        p.pid.u_min = f32(fb.pid.u_min * out);
        p.pid.u_max = f32(fb.pid.u_max * out);
        // Without derivative action its filter is idle; give it a valid cutoff.
        if (p.pid.kd_s == 0.0f && p.pid.derivative_cutoff_Hz == 0.0f) p.pid.derivative_cutoff_Hz = f32(0.25 * s.rate_Hz);
    } else if (fb.kind == "lti") {
        design::Zpk z = fb.model->zpk;
        z.gain *= k;
        const design::Zpk zd = discretise(z, s.rate_Hz, fb.method, fb.prewarp_Hz, false, fb.path + ".model");
        const std::vector<SosSection> sos =
            controller_sos(z, s.rate_Hz, fb.method, fb.prewarp_Hz, c.sample == SampleType::kQ31,
                           m.setup.position.full_scale, fb_out.full_scale, fb.path + ".model");
        p.feedback = FeedbackKind::kSos;
        p.sos_count = static_cast<int>(sos.size());
        for (size_t i = 0; i < sos.size(); ++i) p.sos[i] = sos[i];
        b.controller_sections = p.sos_count;
        if (o.check_realisation) b.notes.push_back(realisation_note(zd, p, c.sample, m.setup.position, fb_out));
    }

    // Reference pre-filter, µm -> µm.
    if (c.prefilter) {
        const std::vector<SosSection> pf =
            controller_sos(c.prefilter->zpk, s.rate_Hz, "tustin", 0.0, c.sample == SampleType::kQ31,
                           m.setup.position.full_scale, m.setup.position.full_scale, c.prefilter->path,
                           kMaxPrefilterSections);
        p.prefilter_count = static_cast<int>(pf.size());
        for (size_t i = 0; i < pf.size(); ++i) p.prefilter[i] = pf[i];
    }

    // Repetitive control.
    if (c.rc.enabled) {
        p.rc_enabled = true;
        p.rc = c.rc.rc;
        int n = c.rc.period_samples;
        if (n == 0) {
            if (!(o.reference_frequency_Hz > 0.0))
                throw ScenarioError(c.rc.path + ".period_samples: \"auto\" needs a periodic reference");
            const double exact = s.rate_Hz / o.reference_frequency_Hz;
            n = static_cast<int>(std::llround(exact));
            if (std::fabs(exact - n) > 1e-6 * exact)
                throw ScenarioError(c.rc.path + ".period_samples: rate / reference frequency = " + format::significant(exact, 8) +
                                    " is not a whole number of ticks");
            if (n < 2 || n > kSimRcCapacity)
                throw ScenarioError(c.rc.path + ".period_samples: rate / reference frequency = " +
                                    std::to_string(n) + " must be in [2, " + std::to_string(kSimRcCapacity) + "]");
        }
        p.rc.period_samples = n;
        if (const Status e = RepetitiveController<float, kSimRcCapacity>::validate(p.rc); !e.ok()) fail(c.rc.path, e);
    }

    // Whole-set validation by the core (e.g. float rounding of sections);
    // its groups named as the scenario file names them.
    auto check = [&](auto* pipe) {
        Status e = pipe->validate(p);
        if (e.ok()) return;
        const std::string group = e.group ? e.group : "";
        const std::string controller = c.controller_path.empty() ? c.path + ".controller" : c.controller_path;
        std::string where = controller;
        if (group == "pid" || group == "sos") where += ".feedback";
        else if (group == "pi" || group == "dahl") where += ".feedforward";
        else if (group == "rc") where += ".rc";
        else if (group == "limits") where = "loop.limits";
        if (where != controller || group.empty()) e.group = nullptr;
        fail(where, e);
    };
    if (c.sample == SampleType::kQ31) {
        auto pipe = std::make_unique<Pipeline<Q31, kSimRcCapacity>>(m.setup);
        check(pipe.get());
    } else {
        auto pipe = std::make_unique<Pipeline<float, kSimRcCapacity>>(m.setup);
        check(pipe.get());
    }
    return b;
}

}  // namespace piezoloop::sim
