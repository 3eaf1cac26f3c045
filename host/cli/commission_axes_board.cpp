// `piezoloop --device ADDR commission --axes x,y[,z]`: a board's coupled axes
// commissioned one by one, then decoupled, as the simulator's
// (commission_axes.hpp), with the board's measurements:
//   1. each axis commissioned with --axis (the others hold with whatever
//      controllers they have; an axis commissioned before holds with its
//      new one), loaded and verified, not yet saved;
//   2. the n x n response, open loop, one axis at a time
//      (link/mimo_measure_session), 1 % of each axis's span about its middle,
//      10 to 100 Hz, with the identity output matrix; D = G0^-1 diag(G0);
//   3. D set as the board's output_matrix and the response measured again;
//   4. each axis driven by a 10 Hz triangle over its range about its centre,
//      the others holding theirs (every axis's wave from one tick), with D
//      and with the identity: the driven axis's e_max and the held axes'
//      peak-to-peak motion (their sensors) in % of the driven range;
//   5. verified and decoupled: D kept and everything saved on the board
//      (unless --no-save); not decoupled: the identity put back.
#include "commission_axes.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "commission_session.hpp"
#include "device_common.hpp"
#include "format/number.hpp"
#include "link/mimo_measure_session.hpp"
#include "link/params_json.hpp"
#include "link/recorded_signals.hpp"
#include "measure/static_decoupling.hpp"
#include "synth/plant_json.hpp"

namespace piezoloop::cli {
namespace {

using nlohmann::json;

link::OutputMatrixParams output_matrix_group(const Eigen::MatrixXd& m) {
    link::OutputMatrixParams g{};
    g.axis_count = static_cast<uint8_t>(m.rows());
    for (Eigen::Index i = 0; i < m.rows(); ++i)
        for (Eigen::Index k = 0; k < m.cols(); ++k)
            g.gain[static_cast<std::size_t>(i) * link::kMaxLinkAxes + static_cast<std::size_t>(k)] =
                static_cast<float>(m(i, k));
    return g;
}

measure::MimoFrfEstimate board_response(hostlink::Client& c, int n, const std::function<bool()>& stop_requested) {
    measure::MimoFrfRequest r;
    r.inputs = n;
    r.rate_Hz = c.info().loop_rate_Hz;
    r.from_Hz = kFrfFrom_Hz;
    r.to_Hz = kFrfTo_Hz;
    double span_V = 1e30;
    for (int a = 0; a < n; ++a) {
        const LimitsConfig l = c.get<link::LimitsParams>(static_cast<uint8_t>(a)).limits;
        span_V = std::min(span_V, static_cast<double>(l.u_max_V - l.u_min_V));
        r.bias_V.push_back(0.5 * (l.u_min_V + l.u_max_V));
    }
    r.amplitude_V = kFrfAmplitude * span_V;
    r.periods = kFrfPeriods;
    r.transient_periods = 1;
    hostlink::MeasureOptions o;
    o.stop_requested = stop_requested;
    return hostlink::run_mimo_frf_device(c, r, o).estimate;
}

// Axis `driven` runs a kCheckFrequency_Hz triangle over range_um about its
// centre, the others hold theirs, every wave from one tick; two periods
// recorded (r and y of the driven axis, y of the others), figures over the
// second.
json cross_motion(hostlink::Client& c, int n, int driven, const std::vector<std::string>& names,
                  const std::map<std::string, double>& range_um, const std::map<std::string, double>& centre_um) {
    for (int a = 0; a < n; ++a) {
        link::TrajectoryParams w;
        w.frequency_Hz = static_cast<float>(kCheckFrequency_Hz);
        w.offset_um = static_cast<float>(centre_um.at(names[static_cast<std::size_t>(a)]));
        if (a == driven) {
            w.waveform = Waveform::kTriangle;
            w.amplitude_um = static_cast<float>(0.5 * range_um.at(names[static_cast<std::size_t>(a)]));
        } else {
            w.waveform = Waveform::kSine;  // amplitude 0: the centre held
        }
        c.set(w, static_cast<uint8_t>(a));
    }
    hostlink::RecordOptions ro;
    ro.axis = static_cast<uint8_t>(driven);
    ro.signals = {hostlink::kSignalR, hostlink::kSignalY};
    ro.signal_axes = {static_cast<uint8_t>(driven), static_cast<uint8_t>(driven)};
    for (int a = 0; a < n; ++a) {
        if (a == driven) continue;
        ro.signals.push_back(hostlink::kSignalY);
        ro.signal_axes.push_back(static_cast<uint8_t>(a));
    }
    ro.duration_s = 2.0 / kCheckFrequency_Hz;
    ro.start_wave = true;
    ro.every_axis = true;
    const hostlink::RecordResult rec = hostlink::record(c, ro);
    c.stop_waves();
    c.disarm();
    if (!rec.complete()) throw hostlink::LinkError("the check's recording is incomplete:" + rec.problems());
    const std::size_t period = static_cast<std::size_t>(std::llround(c.info().loop_rate_Hz / kCheckFrequency_Hz));
    const std::size_t from = rec.frames > period ? rec.frames - period : 0;
    const double range = range_um.at(names[static_cast<std::size_t>(driven)]);
    double e_max = 0.0;
    for (std::size_t i = from; i < rec.frames; ++i) e_max = std::max(e_max, std::fabs(rec.values[0][i] - rec.values[1][i]));
    json held = json::object();
    for (std::size_t k = 2; k < rec.values.size(); ++k) {
        const auto [lo, hi] = std::minmax_element(rec.values[k].begin() + static_cast<std::ptrdiff_t>(from), rec.values[k].end());
        held[names[rec.signal_axes[k]]] = 100.0 * (*hi - *lo) / range;
    }
    return {{"e_max_pct", 100.0 * e_max / range}, {"cross_motion_pct", held}};
}

}  // namespace

json run_axes_commission_board(hostlink::Client& c, const AxesCommission& a, bool save,
                               const std::function<void(const std::string&)>& progress,
                               const std::function<bool()>& stop_requested) {
    auto say = [&](const std::string& line) {
        if (progress) progress(line);
    };
    const int n = c.axis_count();
    if (n < 2) throw std::invalid_argument("--axes: this board has one axis (commission it without --axes)");
    std::vector<std::string> names;
    for (int i = 0; i < n; ++i) names.emplace_back(axis_name(i));
    const std::map<std::string, double> range_um = axes_ranges(a, names, "the board");
    const std::filesystem::path dir(a.out);
    std::filesystem::create_directories(dir);
    const link::OutputMatrixParams before_matrix = c.get<link::OutputMatrixParams>();

    // 1. Each axis.
    json per_axis = json::object();
    bool verified = true;
    std::map<std::string, double> centre_um;
    for (const std::string& name : names) {
        CommissionSession cs;
        cs.axis = name;
        cs.out = (dir / name).string();
        cs.request = a.request;
        cs.request.range_um = range_um.at(name);
        cs.save = false;
        say(name + ": commissioning over " + format::significant(cs.request.range_um, 4) + " um, the other axes holding");
        const json r = run_commission_session(&c, cs, [&](const std::string& line) { say(name + ": " + line); },
                                              stop_requested);
        per_axis[name] = r;
        centre_um[name] = r.value("centre_um", 0.0);
        verified = verified && r.value("verified", false);
    }
    json out;
    out["board"] = c.info().board.data();
    out["axes"] = per_axis;
    out["verified"] = verified;
    if (!verified) {
        out["decoupled"] = false;
        out["failure"] = "an axis failed its verification (its report.md in " + dir.string() + "/<axis> says why): "
                         "nothing was decoupled or saved";
        return out;
    }

    // 2. The response with the identity, its static decoupling.
    const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(n, n);
    c.set(output_matrix_group(identity));
    say("coupling: measuring the " + std::to_string(n) + " x " + std::to_string(n) + " response one axis at a time, " +
        format::significant(kFrfFrom_Hz, 4) + " to " + format::significant(kFrfTo_Hz, 4) + " Hz");
    const measure::MimoFrfEstimate eb = board_response(c, n, stop_requested);
    const measure::StaticDecoupling d = measure::static_decoupling(eb.frequency_Hz, eb.response);

    // 3. Through D.
    c.set(output_matrix_group(d.output_matrix));
    say("coupling: measuring again through the decoupling output matrix");
    const measure::MimoFrfEstimate ea = board_response(c, n, stop_requested);
    bool decoupled = true;
    out["coupling"] = coupling_change(names, eb, ea, decoupled);
    out["coupling"]["static_gain"] = design::matrix_json(d.g0);
    out["coupling"]["condition_1"] = d.condition_1;
    out["output_matrix"] = design::matrix_json(d.output_matrix);
    out["decoupled"] = decoupled;

    // 4. Cross motion with D, then with the identity.
    json checks = json::object();
    for (int i = 0; i < n; ++i) {
        say("check: a " + format::significant(kCheckFrequency_Hz, 4) + " Hz triangle over " +
            format::significant(range_um.at(names[static_cast<std::size_t>(i)]), 4) + " um on " +
            names[static_cast<std::size_t>(i)] + ", the other axes holding their centres");
        checks[names[static_cast<std::size_t>(i)]] = cross_motion(c, n, i, names, range_um, centre_um);
    }
    c.set(output_matrix_group(identity));
    for (int i = 0; i < n; ++i)
        checks[names[static_cast<std::size_t>(i)]]["cross_motion_pct_without_decoupling"] =
            cross_motion(c, n, i, names, range_um, centre_um)["cross_motion_pct"];
    out["check"] = {{"frequency_Hz", kCheckFrequency_Hz}, {"axes", checks}};

    // 5. Kept.
    std::string kept;
    if (!decoupled) {
        c.set(before_matrix);
        kept = "Not decoupled: the output matrix is put back; the axes' controllers are loaded, not saved.";
    } else {
        c.set(output_matrix_group(d.output_matrix));
        if (save) {
            c.save();
            kept = "Saved on the board (`save`): every axis's controller and the output matrix, at its next boot.";
        } else {
            kept = "Loaded, not saved: the board forgets it at its next boot.";
        }
    }
    say(kept);
    out["kept"] = kept;

    std::ostringstream md;
    md << "# Commissioning of the board's axes (" << c.info().board.data() << ", " << c.address() << ")\n\n";
    md << axes_table_md(names, range_um, per_axis);
    md << coupling_table_md(out["coupling"]);
    md << "\nA " << format::significant(kCheckFrequency_Hz, 4)
       << " Hz triangle over each axis's range on the board, the others holding their centres (their sensors' "
          "peak-to-peak in % of the driven axis's range):\n\n"
       << cross_motion_table_md(checks);
    md << "\n" << kept << "\n";
    {
        std::ofstream f(dir / "report.md");
        if (!(f << md.str())) throw std::runtime_error("--out: cannot write " + (dir / "report.md").string());
    }
    out["report"] = (dir / "report.md").string();
    return out;
}

}  // namespace piezoloop::cli
