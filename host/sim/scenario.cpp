#include "sim/scenario.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "piezoloop/axes/axis_matrix.hpp"
#include "piezoloop/axes/coupled_stage.hpp"
#include "piezoloop/pi_generalized.hpp"
#include "piezoloop/pi_inverse.hpp"
#include "sim/design_bridge.hpp"
#include "sim/f32.hpp"

namespace piezoloop::sim {

namespace {

// ---- plant ---------------------------------------------------------------

ConverterConfig parse_converter(const Field& f) {
    f.only({"bits", "min", "max"});
    ConverterConfig c{};
    c.bits = f["bits"].integer(0, 24);
    c.min = f32(f["min"].number());
    c.max = f32(f["max"].number());
    Converter probe;
    f.check(probe.configure(c));
    return c;
}

AmplifierConfig parse_amplifier(const Field& f) {
    f.only({"gain", "input_min_V", "input_max_V", "output_min_V", "output_max_V", "bandwidth_Hz"});
    AmplifierConfig a{};
    a.gain = f32(f["gain"].number());
    if (!(a.gain > 0.0f)) f["gain"].fail("must be > 0");
    a.input_min_V = f32(f["input_min_V"].number());
    a.input_max_V = f32(f["input_max_V"].number());
    if (!(a.input_min_V < a.input_max_V)) f["input_max_V"].fail("must be > input_min_V");
    a.output_min_V = f32(f["output_min_V"].number());
    a.output_max_V = f32(f["output_max_V"].number());
    if (!(a.output_min_V < a.output_max_V)) f["output_max_V"].fail("must be > output_min_V");
    a.bandwidth_Hz = f32(f.number("bandwidth_Hz", 0.0));
    if (a.bandwidth_Hz < 0.0f) f["bandwidth_Hz"].fail("must be >= 0 (0: none)");
    return a;
}

// Sensor pickup of the mains (docs/models.md): {"frequency_Hz": 50,
// "amplitudes_um": [fundamental, 2nd, ...]}.
MainsConfig parse_mains(const Field& f) {
    f.only({"frequency_Hz", "amplitudes_um", "note"});
    MainsConfig m{};
    m.frequency_Hz = f32(f["frequency_Hz"].number_in(1.0, 1000.0));
    const Field a = f["amplitudes_um"];
    const std::vector<double> amps = a.numbers();
    if (amps.empty() || amps.size() > static_cast<size_t>(kMaxMainsHarmonics))
        a.fail("must hold 1 to 8 amplitudes (fundamental, 2nd, 3rd, ... harmonic)");
    for (size_t k = 0; k < amps.size(); ++k) {
        if (!(amps[k] >= 0.0 && amps[k] <= 1000.0)) a.at(k).fail("must be finite and in [0, 1000] um");
        m.amplitudes_um[k] = f32(amps[k]);
    }
    m.count = static_cast<int>(amps.size());
    return m;
}

SensorConfig parse_sensor(const Field& f) {
    f.only({"gain_per_um", "bandwidth_Hz", "noise_rms", "seed", "offset_um", "gain_error", "mains"});
    SensorConfig s{};
    s.gain = f32(f["gain_per_um"].number());
    if (s.gain == 0.0f) f["gain_per_um"].fail("must be non-zero");
    s.bandwidth_Hz = f32(f.number("bandwidth_Hz", 0.0));
    if (s.bandwidth_Hz < 0.0f) f["bandwidth_Hz"].fail("must be >= 0 (0: none)");
    s.noise_rms = f32(f.number("noise_rms", 0.0));
    if (s.noise_rms < 0.0f) f["noise_rms"].fail("must be >= 0");
    if (const auto seed = f.get("seed")) s.seed = static_cast<uint32_t>(seed->integer(1, 2147483647));
    if (const auto o = f.get("offset_um")) s.offset_um = f32(o->number_in(-1000.0, 1000.0));
    if (const auto g = f.get("gain_error")) s.gain_error = f32(g->number_in(-0.5, 0.5));
    if (const auto m = f.get("mains")) s.mains = parse_mains(*m);
    return s;
}

// Logarithmic creep (docs/models.md, 'Creep'): {"percent_per_decade": p,
// "from_s": t0, "to_s": t1}, t1 = t0 * 10^K.
CreepConfig parse_creep(const Field& f) {
    f.only({"percent_per_decade", "from_s", "to_s", "note"});
    CreepConfig c{};
    c.percent_per_decade = f32(f["percent_per_decade"].number_in(0.0, 20.0));
    c.from_s = f32(f["from_s"].number_in(1e-4, 1e4));
    c.to_s = f32(f["to_s"].number());
    CreepLags lags;
    if (const Status st = creep_lags(c, lags); !st.ok()) f[st.field].fail(st.message);
    return c;
}

PiModel scaled(PiModel m, double out_gain) {
    m.p0 = f32(m.p0 * out_gain);
    for (int j = 0; j < m.count; ++j)
        m.weights[static_cast<size_t>(j)] = f32(m.weights[static_cast<size_t>(j)] * out_gain);
    return m;
}

// A superposition of dead zones as a file gives it,
// {"thresholds_um": [d_1, ...], "weights": [q_1, ...]}: 1 to 8, validated
// (pi_model.hpp); an error names the entry as the file has it.
void parse_dead_zones(const Field& z, const char* not_increasing, int& count,
                      std::array<float, kMaxDeadZones>& thresholds, std::array<float, kMaxDeadZones>& weights) {
    z.only({"thresholds_um", "weights"});
    const std::vector<double> d = z["thresholds_um"].numbers();
    const std::vector<double> q = z["weights"].numbers();
    if (d.size() != q.size()) z["weights"].fail("must have as many entries as thresholds_um");
    if (d.empty() || d.size() > static_cast<size_t>(kMaxDeadZones)) z["thresholds_um"].fail("must hold 1 to 8 dead zones");
    std::array<float, kMaxDeadZones> dt{}, qt{};
    for (size_t i = 0; i < d.size(); ++i) {
        dt[i] = f32(d[i]);
        qt[i] = f32(q[i]);
    }
    const int n = static_cast<int>(d.size());
    if (const Status st = validate_dead_zones(n, dt, qt, {"count", "thresholds_um", "weights", not_increasing}); !st.ok()) {
        const Field list = z[st.field];
        if (st.index >= 0) list.at(static_cast<size_t>(st.index)).fail(st.message);
        list.fail(st.message);
    }
    count = n;
    thresholds = dt;
    weights = qt;
}

}  // namespace

HysteresisSpec parse_hysteresis(const Field& f) {
    HysteresisSpec h;
    h.path = f.path();
    h.kind = f["kind"].choice({"none", "pi", "shan_pi", "dahl"});
    if (h.kind == "none") {
        f.only({"kind", "gain_um_per_V", "note"});
        h.core = HysteresisKind::kNone;
        h.gain_um_per_V = f["gain_um_per_V"].number();
        h.plain.p0 = 1.0f;
        h.out_gain = h.gain_um_per_V;
    } else if (h.kind == "pi") {
        // Thresholds in piezo volts, weights in µm/V; without p0 the rule of
        // docs/models.md, 'Prandtl–Ishlinskii model' applies (a first threshold
        // above 0 is the linear term).
        f.only({"kind", "thresholds_V", "weights_um_per_V", "p0_um_per_V", "output_map", "note"});
        const std::vector<double> r = f["thresholds_V"].numbers();
        const std::vector<double> p = f["weights_um_per_V"].numbers();
        if (r.size() != p.size()) f["weights_um_per_V"].fail("must have as many entries as thresholds_V");
        if (r.size() > static_cast<size_t>(kMaxPlayOperators) + 1)
            f["thresholds_V"].fail("at most 16 play operators (17 without p0)");
        std::vector<float> rf(r.begin(), r.end()), pf(p.begin(), p.end());
        float p0 = 0.0f;
        const auto p0f = f.get("p0_um_per_V");
        if (p0f) p0 = f32(p0f->number());
        PiModel m{};
        f.check(pi_model_from_lists(rf.data(), pf.data(), static_cast<int>(rf.size()), p0f ? &p0 : nullptr, m));
        h.core = HysteresisKind::kPi;
        h.pi = m;
        h.plain = m;
        // Kuhnen's modified PI: S on the PI's output, y = S(PI[v]),
        // S(x) = x + sum_i q_i max(x - d_i, 0) in µm (plant.hpp).
        if (const auto z = f.get("output_map")) {
            OutputMap& o = h.output_map;
            parse_dead_zones(*z, "must keep the output map increasing: 1 + the weights up to it > 0", o.count,
                             o.thresholds_um, o.weights);
        }
    } else if (h.kind == "shan_pi") {
        // Shan2012 eq. 4-5 in its own units: model input = input_per_V * piezo
        // voltage, displacement = output_um * model output.
        f.only({"kind", "g0", "g1", "lambda", "delta", "rho", "count", "input_per_V", "output_um", "note"});
        GeneralizedPi g{};
        g.g0 = f["g0"].number();
        g.g1 = f["g1"].number();
        g.lambda = f["lambda"].number();
        g.delta = f["delta"].number();
        g.rho = f["rho"].number();
        g.count = f["count"].integer(1, kMaxPlayOperators);
        const double in = f["input_per_V"].number();
        const double out = f["output_um"].number();
        if (!(in > 0.0)) f["input_per_V"].fail("must be > 0");
        if (!(out > 0.0)) f["output_um"].fail("must be > 0");
        PiModel m{};
        f.check(shan_forward_model(g, m));
        h.plain = m;
        h.plain.input_gain = 1.0f;
        h.plain.input_offset = 0.0f;
        h.in_gain = g.g0 * in;
        h.in_offset = g.g1;
        h.out_gain = out;
        m.input_gain = f32(g.g0 * in);
        h.pi = scaled(m, out);
        h.core = HysteresisKind::kPi;
    } else {
        f.only({"kind", "alpha1", "alpha2", "beta1", "beta2", "gamma_a", "ga", "note"});
        DahlParams d{};
        d.alpha1 = f32(f["alpha1"].number());
        d.alpha2 = f32(f["alpha2"].number());
        d.beta1 = f32(f["beta1"].number());
        d.beta2 = f32(f["beta2"].number());
        d.gamma_a = f32(f["gamma_a"].number());
        d.ga = f32(f["ga"].number());
        f.check(validate(d));
        h.core = HysteresisKind::kDahl;
        h.dahl = d;
    }
    return h;
}

namespace {

// A stage's dynamics settle: every pole in the left half-plane, and none so
// near s = 0 that the loop rate's discretisation rounds it onto z = 1 (an
// integrator: |p| / rate below 1e-12, where exp(-|p| / rate) is 1 within a
// few ulps of double).
void check_stage_poles(const Field& model, const design::Zpk& zpk, double rate_Hz) {
    for (const design::cplx p : zpk.poles) {
        char pole[96];
        std::snprintf(pole, sizeof pole, "pole %.6g %c %.6gj rad/s", p.real(), p.imag() < 0 ? '-' : '+',
                      std::fabs(p.imag()));
        if (!(p.real() < 0.0))
            model.fail(std::string(pole) + " is not in the left half-plane: a stage's dynamics must settle (every pole with "
                              "Re < 0)");
        if (std::abs(p) < 1e-12 * rate_Hz)
            model.fail(std::string(pole) + " is at s = 0 at the loop rate's resolution (|p| < 1e-12 x loop.rate_Hz): its "
                              "discretisation is an integrator, and a stage's dynamics must settle");
    }
}

// The fields of a single-axis plant (and of each of plant.axes[], which also
// holds a name).
PlantSpec parse_axis_plant(const Field& f, const std::filesystem::path& base, double rate_Hz, bool named) {
    std::vector<std::string> fields{"dac", "amplifier", "hysteresis", "dynamics", "sensor", "adc", "creep", "drift_um_per_s", "note"};
    if (named) fields.insert(fields.begin(), "name");
    f.only(fields);
    PlantSpec p;
    p.dac = parse_converter(f["dac"]);
    p.amplifier = parse_amplifier(f["amplifier"]);
    p.hysteresis = parse_hysteresis(f["hysteresis"]);
    if (const auto d = f.get("dynamics")) {
        d->only({"model", "normalise_dc", "discretisation", "note"});
        LinearSpec lin = read_linear_model((*d)["model"], base);
        if (design::is_discrete(lin.zpk.ts)) (*d)["model"].fail("the plant dynamics must be continuous (no ts)");
        check_stage_poles((*d)["model"], lin.zpk, rate_Hz);
        const bool normalise = d->get("normalise_dc") ? (*d)["normalise_dc"].boolean() : false;
        if (normalise) lin.zpk = normalise_dc_gain(lin.zpk, (*d)["model"]);
        p.dynamics = lin;
        if (const auto m = d->get("discretisation")) p.discretisation = m->choice({"zoh", "tustin", "matched"});
    }
    p.sensor = parse_sensor(f["sensor"]);
    p.adc = parse_converter(f["adc"]);
    if (const auto c = f.get("creep")) p.creep = parse_creep(*c);
    if (const auto d = f.get("drift_um_per_s")) p.drift_um_per_s = f32(d->number_in(-10.0, 10.0));
    // What the float stage at the loop rate needs (compared in float, as it
    // configures).
    const float half_rate = 0.5f * f32(rate_Hz);
    if (p.amplifier.bandwidth_Hz >= half_rate)
        f["amplifier"]["bandwidth_Hz"].fail("must be below rate / 2 (the float stage discretises it)");
    if (p.sensor.bandwidth_Hz >= half_rate)
        f["sensor"]["bandwidth_Hz"].fail("must be below rate / 2 (the float stage discretises it)");
    if (p.sensor.mains.count > 0 && !(static_cast<double>(p.sensor.mains.frequency_Hz) * p.sensor.mains.count < 0.5 * rate_Hz))
        f["sensor"]["mains"]["amplitudes_um"].fail("every harmonic must lie below rate / 2");
    if (p.creep.percent_per_decade > 0.0f && !(rate_Hz * p.creep.from_s >= 2.0))
        f["creep"]["from_s"].fail("must be at least 2 samples (2 / rate)");
    if (p.creep.percent_per_decade > 0.0f && !(rate_Hz * p.creep.to_s <= 4.0e9))
        f["creep"]["to_s"].fail("must be below 4e9 samples (4e9 / rate)");
    return p;
}

std::string name_list(const std::vector<AxisSpec>& axes, const char* separator = ", ") {
    std::string list;
    for (const AxisSpec& a : axes) list += (list.empty() ? "" : separator) + a.name;
    return list;
}

int axis_index(const Field& f, const std::vector<AxisSpec>& axes) {
    const std::string n = f.string();
    for (size_t i = 0; i < axes.size(); ++i)
        if (axes[i].name == n) return static_cast<int>(i);
    f.fail("must be one of the axis names " + name_list(axes) + " (got \"" + n + "\")");
}

CouplingSpec parse_coupling(const Field& f, const std::vector<AxisSpec>& axes, double rate_Hz) {
    f.only({"from", "to", "dc_gain", "mode_Hz", "damping", "discretisation", "note"});
    CouplingSpec c;
    c.path = f.path();
    c.from_axis = axis_index(f["from"], axes);
    c.to_axis = axis_index(f["to"], axes);
    c.from = axes[static_cast<size_t>(c.from_axis)].name;
    c.to = axes[static_cast<size_t>(c.to_axis)].name;
    if (c.from_axis == c.to_axis) f["to"].fail("must differ from `from` (\"" + c.from + "\"): no path from an axis to itself");
    c.dc_gain = f["dc_gain"].number_in(-1.0, 1.0);
    if (c.dc_gain == 0.0) f["dc_gain"].fail("must be non-zero (leave the path out for none)");
    c.mode_Hz = f["mode_Hz"].number();
    if (!(c.mode_Hz > 0.0 && c.mode_Hz < 0.5 * rate_Hz)) f["mode_Hz"].fail("must be in (0, rate / 2)");
    c.damping = f["damping"].number_in(1e-3, 10.0);
    if (const auto m = f.get("discretisation")) c.discretisation = m->choice({"zoh", "tustin", "matched"});
    return c;
}

// A plant: single-axis, or {"axes": [...], "coupling": [...]}.
void parse_plant(const Field& f, const std::filesystem::path& base, double rate_Hz, Scenario& s) {
    if (!f.get("axes")) {
        if (f.get("coupling")) Field(f.json(), f.child_path("axes")).fail("required with plant.coupling: the axes the paths join");
        s.plant = parse_axis_plant(f, base, rate_Hz, false);
        return;
    }
    f.only({"axes", "coupling", "note"});
    const Field axes = f["axes"];
    const size_t n = axes.size();
    if (n < 1 || n > static_cast<size_t>(kMaxStageAxes))
        axes.fail("must hold 1 to " + std::to_string(kMaxStageAxes) + " axes (got " + std::to_string(n) + ")");
    for (size_t i = 0; i < n; ++i) {
        const Field a = axes.at(i);
        AxisSpec ax;
        ax.path = a.path();
        ax.name = a["name"].string();
        if (ax.name.empty()) a["name"].fail("must not be empty");
        for (const AxisSpec& other : s.axes)
            if (other.name == ax.name) a["name"].fail("duplicate axis name \"" + ax.name + "\"");
        ax.plant = parse_axis_plant(a, base, rate_Hz, true);
        s.axes.push_back(std::move(ax));
    }
    if (const auto c = f.get("coupling")) {
        for (size_t k = 0; k < c->size(); ++k) {
            CouplingSpec p = parse_coupling(c->at(k), s.axes, rate_Hz);
            for (const CouplingSpec& q : s.coupling)
                if (q.from_axis == p.from_axis && q.to_axis == p.to_axis)
                    c->at(k).fail("a path from " + p.from + " to " + p.to + " is given already (" + q.path + ")");
            s.coupling.push_back(std::move(p));
        }
    }
    s.plant = s.axes.front().plant;
}

// ---- controller ----------------------------------------------------------

FeedforwardSpec parse_feedforward(const Field& f) {
    FeedforwardSpec s;
    s.path = f.path();
    s.kind = f["kind"].choice({"none", "gain", "pi_inverse", "pi_compensator", "dahl"});
    if (s.kind == "none") {
        f.only({"kind"});
    } else if (s.kind == "gain") {
        f.only({"kind", "V_per_um"});
        s.V_per_um = f["V_per_um"].number();
    } else if (s.kind == "pi_inverse") {
        f.only({"kind", "of", "placement"});
        if (const auto o = f.get("of")) s.of = o->choice({"base", "plant"});
        if (const auto p = f.get("placement")) s.placement = p->choice({"feedforward", "series"});
    } else if (s.kind == "pi_compensator") {
        // A compensator given directly, r (µm) -> u (V); in series, after a
        // feedback whose output is in µm.
        f.only({"kind", "thresholds_um", "weights_V_per_um", "p0_V_per_um", "input_offset_um", "dead_zones", "placement"});
        if (const auto p = f.get("placement")) s.placement = p->choice({"feedforward", "series"});
        const std::vector<double> r = f["thresholds_um"].numbers();
        const std::vector<double> p = f["weights_V_per_um"].numbers();
        if (r.size() != p.size()) f["weights_V_per_um"].fail("must have as many entries as thresholds_um");
        if (r.size() > static_cast<size_t>(kMaxPlayOperators)) f["thresholds_um"].fail("at most 16 play operators");
        std::vector<float> rf(r.begin(), r.end()), pf(p.begin(), p.end());
        const float p0 = f32(f["p0_V_per_um"].number());
        f.check(pi_model_from_lists(rf.data(), pf.data(), static_cast<int>(rf.size()), &p0, s.pi));
        // Added to r before the operators (a model's output offset taken off).
        if (const auto o = f.get("input_offset_um")) s.pi.input_offset = f32(o->number_in(-1e4, 1e4));
        // Kuhnen's modified PI: the inverse of the output map on r first,
        // g(r) = r + sum_i q_i max(r - d_i, 0) (identify pi's
        // output_nonlinearity.inverse).
        if (const auto z = f.get("dead_zones"))
            parse_dead_zones(*z, "must keep the input map increasing: 1 + the weights up to it > 0", s.pi.dead_zones,
                             s.pi.dead_zone_thresholds, s.pi.dead_zone_weights);
    } else {
        f.only({"kind", "params", "identify"});
        const auto params = f.get("params");
        const auto ident = f.get("identify");
        if (!!params == !!ident) f.fail("dahl feedforward needs exactly one of params or identify");
        if (params) {
            HysteresisSpec h = parse_hysteresis(*params);
            if (h.kind != "dahl") (*params)["kind"].fail("must be dahl");
            s.dahl = h.dahl;
        } else {
            const Field& i = *ident;
            i.only({"frequency_Hz", "amplitudes_V", "cycles", "gamma_a", "decimate"});
            DahlIdentifySpec d;
            d.frequency_Hz = i["frequency_Hz"].number_in(1e-3, 1e4);
            d.amplitudes_V = i["amplitudes_V"].numbers();
            if (d.amplitudes_V.empty()) i["amplitudes_V"].fail("must not be empty");
            for (size_t k = 0; k < d.amplitudes_V.size(); ++k)
                if (!(d.amplitudes_V[k] > 0.0)) i["amplitudes_V"].at(k).fail("must be > 0");
            if (const auto c = i.get("cycles")) d.cycles = c->integer(1, 100);
            if (const auto g = i.get("gamma_a")) d.gamma_a = g->number();
            if (const auto dd = i.get("decimate")) d.decimate = dd->integer(1, 10000);
            s.identify = d;
        }
    }
    return s;
}

FeedbackSpec parse_feedback(const Field& f, const std::filesystem::path& base) {
    FeedbackSpec s;
    s.path = f.path();
    s.kind = f["kind"].choice({"none", "pid", "lti"});
    if (s.kind == "none") {
        f.only({"kind"});
        return s;
    }
    if (const auto e = f.get("error_per_um")) {
        s.error_per_um = e->number();
        if (!(s.error_per_um > 0.0)) e->fail("must be > 0");
    }
    if (s.kind == "pid") {
        f.only({"kind", "error_per_um", "kp", "ki_per_s", "kd_s", "derivative_cutoff_Hz", "u_min_V", "u_max_V"});
        s.pid.kp = f32(f["kp"].number());
        s.pid.ki_per_s = f32(f.number("ki_per_s", 0.0));
        s.pid.kd_s = f32(f.number("kd_s", 0.0));
        s.pid.derivative_cutoff_Hz = f32(f.number("derivative_cutoff_Hz", 0.0));
        s.pid.u_min = f32(f["u_min_V"].number());
        s.pid.u_max = f32(f["u_max_V"].number());
    } else {
        f.only({"kind", "error_per_um", "model", "method", "prewarp_Hz"});
        s.model = read_linear_model(f["model"], base);
        if (design::is_discrete(s.model->zpk.ts)) f["model"].fail("must be continuous (no ts): it is discretised at the loop rate");
        if (const auto m = f.get("method")) s.method = m->choice({"tustin", "zoh", "matched"});
        if (const auto w = f.get("prewarp_Hz")) s.prewarp_Hz = w->number_in(0.0, 1e9);
    }
    return s;
}

RcSpec parse_rc(const Field& f) {
    f.only({"period_samples", "m1", "m2", "k_rc", "q"});
    RcSpec s;
    s.path = f.path();
    s.enabled = true;
    s.rc = RepetitiveConfig{};
    if (const auto n = f.get("period_samples")) {
        if (n->is_string()) {
            if (n->string() != "auto") n->fail("must be an integer or \"auto\" (loop rate / reference frequency)");
        } else {
            s.period_samples = n->integer(2, kSimRcCapacity);
        }
    }
    if (const auto m = f.get("m1")) s.rc.m1 = m->integer(0, kSimRcCapacity);
    if (const auto m = f.get("m2")) s.rc.m2 = m->integer(0, kSimRcCapacity);
    if (const auto k = f.get("k_rc")) s.rc.k_rc = f32(k->number());
    if (!(s.rc.k_rc > 0.0f && s.rc.k_rc < 2.0f)) f["k_rc"].fail("must be in (0, 2)");
    if (const auto q = f.get("q")) {
        q->only({"b0", "b1", "b2", "a1", "a2"});
        s.rc.q = SosSection{q->number("b0", 0.0), q->number("b1", 0.0), q->number("b2", 0.0), q->number("a1", 0.0),
                            q->number("a2", 0.0)};
    }
    // Everything but N is checked now; N (when auto) at build time.
    RepetitiveConfig probe = s.rc;
    probe.period_samples = s.period_samples != 0 ? s.period_samples : kSimRcCapacity;
    f.check(RepetitiveController<float, kSimRcCapacity>::validate(probe));
    return s;
}

// The controller fields of one loop (a single-axis case's controller, or one
// axis's under controller.axes).
void parse_controller(const Field& ctl, const std::filesystem::path& base, CaseSpec& c,
                      std::initializer_list<const char*> extra = {}) {
    std::vector<std::string> fields{"prefilter", "feedforward", "feedback", "rc"};
    fields.insert(fields.end(), extra.begin(), extra.end());
    ctl.only(fields);
    c.controller_path = ctl.path();
    if (const auto pf = ctl.get("prefilter")) c.prefilter = read_linear_model(*pf, base);
    if (const auto ff = ctl.get("feedforward")) c.feedforward = parse_feedforward(*ff);
    if (const auto fb = ctl.get("feedback")) c.feedback = parse_feedback(*fb, base);
    if (const auto rc = ctl.get("rc")) c.rc = parse_rc(*rc);
    if (c.rc.enabled && c.feedback.kind == "none")
        ctl["rc"].fail("repetitive control plugs into a feedback loop: give controller.feedback");
}

// An n x n matrix as rows of numbers, each coefficient checked by the core
// (magnitude, conditioning) through validate_matrix below.
std::vector<std::vector<double>> parse_matrix(const Field& f, size_t n, const char* rows_are) {
    if (!f.is_array() || f.size() != n)
        f.fail("must be " + std::to_string(n) + " rows (" + rows_are + ") of " + std::to_string(n) + " numbers");
    std::vector<std::vector<double>> m;
    for (size_t i = 0; i < n; ++i) {
        const Field row = f.at(i);
        if (!row.is_array() || row.size() != n) row.fail("must hold " + std::to_string(n) + " numbers (one per axis)");
        m.push_back(row.numbers());
    }
    return m;
}

template <int N>
void validate_matrices(const Field& ctl, const CaseSpec& c) {
    if (!c.output_matrix.empty()) {
        AxisMatrix<N> m{};
        for (int i = 0; i < N; ++i)
            for (int j = 0; j < N; ++j) m.m[i][j] = f32(c.output_matrix[static_cast<size_t>(i)][static_cast<size_t>(j)]);
        Status st = validate_output_matrix(m);
        st.group = nullptr;  // "output_matrix[i][j]" names it under the controller
        ctl.check(st);
    }
    if (!c.input_matrix.empty() || !c.input_offset_um.empty()) {
        InputMatrix<N> m{};
        for (int i = 0; i < N; ++i) {
            for (int j = 0; j < N && !c.input_matrix.empty(); ++j)
                m.gain.m[i][j] = f32(c.input_matrix[static_cast<size_t>(i)][static_cast<size_t>(j)]);
            if (!c.input_offset_um.empty())
                m.offset_um[static_cast<size_t>(i)] = f32(c.input_offset_um[static_cast<size_t>(i)]);
        }
        Status st = validate_input_matrix(m);
        st.group = nullptr;
        ctl.check(st);
    }
}

// A case of a stage of coupled axes: controller.axes.<name> per axis (or one
// controller for every axis), and the optional matrices.
void parse_multi_axis_controller(const Field& ctl, const std::filesystem::path& base, const std::vector<AxisSpec>& axes,
                                 CaseSpec& c) {
    const size_t n = axes.size();
    // One axis's case: the case's name, label, sample type and path, with
    // the controller read from f (keys besides a controller's allowed).
    auto axis_case = [&](const Field& f, std::initializer_list<const char*> also = {}) {
        CaseSpec a;
        a.name = c.name;
        a.label = c.label;
        a.sample = c.sample;
        a.plant_hysteresis = c.plant_hysteresis;
        a.path = c.path;
        parse_controller(f, base, a, also);
        return a;
    };
    if (const auto ax = ctl.get("axes")) {
        ctl.only({"axes", "output_matrix", "input_matrix", "input_offset_um"});
        if (!ax->is_object()) ax->fail("must be an object: a controller per axis name (" + name_list(axes) + ")");
        for (const auto& item : ax->json().items()) {
            bool known = false;
            for (const AxisSpec& a : axes) known = known || a.name == item.key();
            if (!known) (*ax)[item.key().c_str()].fail("no axis of that name (axes: " + name_list(axes) + ")");
        }
        for (const AxisSpec& a : axes) {
            if (!ax->has(a.name.c_str()))
                ax->fail("axis " + a.name + " has no controller (give one for each of " + name_list(axes) + ")");
            c.axis_cases.push_back(axis_case((*ax)[a.name.c_str()]));
        }
    } else {
        c.axis_cases.assign(n, axis_case(ctl, {"output_matrix", "input_matrix", "input_offset_um"}));
    }
    c.controller_path = ctl.path();
    if (n == 1)
        for (const char* key : {"output_matrix", "input_matrix", "input_offset_um"})
            if (ctl.get(key)) ctl[key].fail("a stage of one axis has no matrices (leave it out)");
    if (const auto m = ctl.get("output_matrix")) c.output_matrix = parse_matrix(*m, n, "one per channel");
    if (const auto m = ctl.get("input_matrix")) c.input_matrix = parse_matrix(*m, n, "one per axis position");
    if (const auto o = ctl.get("input_offset_um")) {
        if (!o->is_array() || o->size() != n) o->fail("must hold " + std::to_string(n) + " numbers (one per axis, um)");
        c.input_offset_um = o->numbers();
    }
    if (n == 2) validate_matrices<2>(ctl, c);
    if (n == 3) validate_matrices<3>(ctl, c);
    if (n == 1) validate_matrices<1>(ctl, c);
}

CaseSpec parse_case(const Field& f, const std::filesystem::path& base, const std::vector<AxisSpec>& axes) {
    f.only({"name", "label", "sample", "plant", "controller", "note"});
    CaseSpec c;
    c.path = f.path();
    c.name = f["name"].string();
    if (c.name.empty()) f["name"].fail("must not be empty");
    c.label = f.string("label", c.name);
    c.note = f.string("note", "");
    if (const auto s = f.get("sample")) c.sample = s->choice({"float", "q31"}) == "q31" ? SampleType::kQ31 : SampleType::kFloat;
    if (const auto p = f.get("plant")) {
        if (axes.size() > 1) p->fail("a stage of coupled axes takes every axis's plant from plant.axes (leave it out)");
        p->only({"hysteresis"});
        c.plant_hysteresis = parse_hysteresis((*p)["hysteresis"]);
    }
    const Field ctl = f["controller"];
    if (axes.empty()) {
        parse_controller(ctl, base, c);
    } else {
        // A plant of axes (one included): its controllers per axis. The
        // case's own controller fields are axis 0's, for the commands that
        // run one axis.
        parse_multi_axis_controller(ctl, base, axes, c);
        const std::string path = c.controller_path;
        const CaseSpec& first = c.axis_cases.front();
        c.prefilter = first.prefilter;
        c.feedforward = first.feedforward;
        c.feedback = first.feedback;
        c.rc = first.rc;
        c.controller_path = c.axis_cases.size() == 1 ? first.controller_path : path;
    }
    return c;
}

// ---- experiments -----------------------------------------------------------

ExperimentSpec parse_experiment(const Field& f, const Scenario& sc) {
    f.only({"name", "kind", "title", "note", "cases", "waveform", "frequency_Hz", "frequencies_Hz", "amplitudes_V",
            "amplitude_um", "amplitudes_um", "offset", "periods", "min_duration_s", "steps_um", "hold_s"});
    ExperimentSpec e;
    e.path = f.path();
    e.name = f["name"].string();
    e.kind = f["kind"].choice({"loops", "tracking", "bode", "steps", "growth"});
    e.title = f.string("title", e.name);
    e.note = f.string("note", "");
    const Field cases = f["cases"];
    for (size_t i = 0; i < cases.size(); ++i) {
        const std::string n = cases.at(i).string();
        bool found = false;
        for (const CaseSpec& c : sc.cases) found = found || c.name == n;
        if (!found) cases.at(i).fail("no case named \"" + n + "\" in cases[]");
        e.cases.push_back(n);
    }
    if (e.cases.empty()) cases.fail("must name at least one case");
    if (const auto w = f.get("waveform")) {
        e.waveform_name = w->choice({"triangle", "sine"});
        e.waveform = e.waveform_name == "sine" ? Waveform::kSine : Waveform::kTriangle;
    }
    const double nyquist = 0.5 * sc.rate_Hz;
    if (const auto fr = f.get("frequency_Hz")) e.frequencies_Hz = {fr->number_in(1e-4, nyquist)};
    if (const auto fr = f.get("frequencies_Hz")) {
        e.frequencies_Hz = fr->numbers();
        for (size_t i = 0; i < e.frequencies_Hz.size(); ++i)
            if (!(e.frequencies_Hz[i] >= 1e-4 && e.frequencies_Hz[i] < nyquist))
                fr->at(i).fail("must be in [1e-4, rate / 2)");
    }
    if (const auto a = f.get("amplitudes_V")) e.amplitudes_V = a->numbers();
    if (const auto a = f.get("amplitude_um")) e.amplitudes_um = {a->number_in(1e-6, 1e3)};
    if (const auto a = f.get("amplitudes_um")) e.amplitudes_um = a->numbers();
    e.offset = sc.offset;
    if (const auto o = f.get("offset")) e.offset = o->choice({"unipolar", "bipolar"});
    if (const auto p = f.get("periods")) e.periods = p->integer(1, 100000);
    if (const auto d = f.get("min_duration_s")) e.min_duration_s = d->number_in(0.0, 1e3);
    if (const auto s = f.get("steps_um")) e.steps_um = s->numbers();
    if (const auto h = f.get("hold_s")) e.hold_s = h->number_in(1e-5, 100.0);
    if (e.kind == "steps") {
        if (e.steps_um.empty()) f["steps_um"].fail("required for kind steps");
        if (e.steps_um.size() > 256) f["steps_um"].fail("at most 256 levels");
    } else {
        if (e.frequencies_Hz.empty()) f["frequencies_Hz"].fail("required (or frequency_Hz) for this kind");
        if (e.kind == "loops" && e.amplitudes_V.empty() && e.amplitudes_um.empty())
            f["amplitudes_V"].fail("required (or amplitudes_um) for kind loops");
        if (e.kind != "loops" && e.amplitudes_um.empty())
            f["amplitude_um"].fail("required (or amplitudes_um) for this kind");
        if (e.kind == "loops" && e.frequencies_Hz.size() != 1) f["frequency_Hz"].fail("loops use one frequency");
    }
    for (size_t i = 0; i < e.amplitudes_V.size(); ++i)
        if (!(e.amplitudes_V[i] > 0.0)) f["amplitudes_V"].at(i).fail("must be > 0");
    for (size_t i = 0; i < e.amplitudes_um.size(); ++i)
        if (!(e.amplitudes_um[i] > 0.0)) f.get("amplitudes_um") ? f["amplitudes_um"].at(i).fail("must be > 0")
                                                                 : f["amplitude_um"].fail("must be > 0");
    return e;
}

}  // namespace

const CaseSpec& Scenario::find_case(const std::string& n) const {
    for (const CaseSpec& c : cases)
        if (c.name == n) return c;
    std::string list;
    for (const CaseSpec& c : cases) {
        if (!list.empty()) list += ", ";
        list += c.name;
    }
    throw ScenarioError("case \"" + n + "\": no such case in " + name + " (cases: " + list + ")");
}

Scenario parse_scenario(const nlohmann::json& j, const std::filesystem::path& base_dir) {
    const Field top(j, "");
    top.only({"scenario", "title", "source", "notes", "loop", "plant", "reference", "cases", "experiments"});
    Scenario s;
    s.name = top["scenario"].string();
    s.title = top.string("title", s.name);
    s.source = top.string("source", "");
    if (const auto n = top.get("notes"))
        for (size_t i = 0; i < n->size(); ++i) s.notes.push_back(n->at(i).string());

    const Field loop = top["loop"];
    loop.only({"rate_Hz", "position_full_scale_um", "voltage_full_scale_V", "hard_limits", "limits"});
    s.rate_Hz = loop["rate_Hz"].number_in(100.0, 1e7);
    s.setup.rate_Hz = f32(s.rate_Hz);
    s.setup.position = SignalScale{f32(loop["position_full_scale_um"].number_in(1e-3, 1e6))};
    s.setup.voltage = SignalScale{f32(loop["voltage_full_scale_V"].number_in(1e-3, 1e6))};
    const Field hard = loop["hard_limits"];
    hard.only({"u_min_V", "u_max_V", "slew_V_per_s"});
    s.setup.hard = HardLimits{f32(hard["u_min_V"].number()), f32(hard["u_max_V"].number()),
                              f32(hard["slew_V_per_s"].number())};
    {
        OutputLimiter<float> probe(s.setup.hard, s.setup.rate_Hz, s.setup.voltage);
        hard.check(probe.hard_status());
    }
    s.limits = LimitsConfig{s.setup.hard.u_min_V, s.setup.hard.u_max_V, s.setup.hard.slew_max_V_per_s, 0.0f};
    if (const auto l = loop.get("limits")) {
        l->only({"u_min_V", "u_max_V", "slew_V_per_s", "saturation_trip_s"});
        s.limits.u_min_V = f32(l->number("u_min_V", s.limits.u_min_V));
        s.limits.u_max_V = f32(l->number("u_max_V", s.limits.u_max_V));
        s.limits.slew_V_per_s = f32(l->number("slew_V_per_s", s.limits.slew_V_per_s));
        s.limits.saturation_trip_s = f32(l->number("saturation_trip_s", 0.0));
        l->check(validate(s.limits, s.setup.hard));
    }

    parse_plant(top["plant"], base_dir, s.rate_Hz, s);

    const Field ref = top["reference"];
    ref.only({"nominal_um_per_V", "offset"});
    s.nominal_um_per_V = ref["nominal_um_per_V"].number();
    if (!(s.nominal_um_per_V > 0.0)) ref["nominal_um_per_V"].fail("must be > 0");
    if (const auto o = ref.get("offset")) s.offset = o->choice({"unipolar", "bipolar"});

    const Field cases = top["cases"];
    for (size_t i = 0; i < cases.size(); ++i) {
        CaseSpec c = parse_case(cases.at(i), base_dir, s.axes);
        for (const CaseSpec& other : s.cases)
            if (other.name == c.name) cases.at(i)["name"].fail("duplicate case name \"" + c.name + "\"");
        s.cases.push_back(std::move(c));
    }
    if (s.cases.empty()) cases.fail("must hold at least one case");
    if (const auto ex = top.get("experiments"))
        for (size_t i = 0; i < ex->size(); ++i) s.experiments.push_back(parse_experiment(ex->at(i), s));
    return s;
}

void require_single_axis(const Scenario& s, const std::string& command) {
    if (!s.multi_axis()) return;
    throw std::invalid_argument("multi-axis scenario: " + command + " runs single-axis stages only so far (" + s.name +
                                ": plant.axes " + name_list(s.axes) + ")");
}

std::string axis_names(const Scenario& s, const char* separator) { return name_list(s.axes, separator); }

Scenario axis_alone(const Scenario& s, std::size_t axis) {
    Scenario alone = s;
    alone.plant = s.axes.at(axis).plant;
    alone.axes.clear();
    alone.coupling.clear();
    return alone;
}

std::size_t axis_named(const Scenario& s, const std::string& name, const std::string& option) {
    for (std::size_t i = 0; i < s.axes.size(); ++i)
        if (s.axes[i].name == name) return i;
    throw std::invalid_argument(option + ": \"" + name + "\" is not an axis of the stage (axes: " + name_list(s.axes) +
                                ")");
}

design::Zpk coupling_model(const CouplingSpec& c) {
    // dc_gain w^2 / (s^2 + 2 zeta w s + w^2): poles -zeta w +- j w sqrt(1 - zeta^2)
    // (underdamped), else two real poles -w (zeta -+ sqrt(zeta^2 - 1)).
    const double w = 2.0 * M_PI * c.mode_Hz, z = c.damping;
    design::Zpk m;
    if (z < 1.0) {
        const double wd = w * std::sqrt(1.0 - z * z);
        m.poles = {{-z * w, wd}, {-z * w, -wd}};
    } else {
        const double r = std::sqrt(z * z - 1.0);
        m.poles = {{-w * (z - r), 0.0}, {-w * (z + r), 0.0}};
    }
    m.gain = c.dc_gain * w * w;
    return m;
}

Scenario load_scenario(const std::filesystem::path& file) {
    nlohmann::json j;
    try {
        j = hostjson::read_file(file.string());
    } catch (const ScenarioError& e) {
        // Errors of the text itself name the file, or the field (a
        // duplicate key, a number no double holds): prefixed by the file.
        const std::string m = e.what();
        if (m.rfind(file.string(), 0) == 0) throw;
        throw ScenarioError(file.filename().string() + ": " + m);
    }
    try {
        Scenario s = parse_scenario(j, file.parent_path());
        s.file = file;
        return s;
    } catch (const ScenarioError& e) {
        throw ScenarioError(file.filename().string() + ": " + e.what());
    }
}

}  // namespace piezoloop::sim
