// TEMPORARY bodies: the toolkit's model files, c2d and SOS split
// (design/model_json.hpp, c2d.hpp, sos.hpp) are being written; until they
// land these minimal versions stand in for them, built on design/lti_convert.
#include "sim/design_bridge.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>

#include <unsupported/Eigen/MatrixFunctions>

#include "design/freqresp.hpp"
#include "design/lti_convert.hpp"

namespace piezoloop::sim {

namespace {

design::cplx read_complex(const Field& f) {
    if (f.json().is_number()) return {f.number(), 0.0};
    if (f.size() != 2) f.fail("must be a number or [re, im]");
    return {f.at(0).number(), f.at(1).number()};
}

design::Zpk parse_model(const Field& f) {
    f.only({"num", "den", "zeros", "poles", "gain", "series", "ts", "name", "note", "source", "units"});
    design::Zpk z;
    try {
        if (f.has("series")) {
            const Field s = f["series"];
            std::vector<design::Zpk> parts;
            for (size_t i = 0; i < s.size(); ++i) parts.push_back(parse_model(s.at(i)));
            z = design::series(parts);
        } else if (f.has("num")) {
            design::Tf tf{f["num"].numbers(), f["den"].numbers(), 0.0};
            z = design::tf2zpk(tf);
        } else {
            const Field zs = f["zeros"], ps = f["poles"];
            for (size_t i = 0; i < zs.size(); ++i) z.zeros.push_back(read_complex(zs.at(i)));
            for (size_t i = 0; i < ps.size(); ++i) z.poles.push_back(read_complex(ps.at(i)));
            z.gain = f["gain"].number();
        }
    } catch (const ScenarioError&) {
        throw;
    } catch (const std::exception& e) {
        f.fail(e.what());
    }
    if (const auto ts = f.get("ts")) z.ts = ts->number();
    return z;
}

design::Zpk add_zero_at_origin(design::Zpk z) {
    z.zeros.push_back({0.0, 0.0});
    return z;
}

design::Zpk c2d_zoh(const design::Zpk& zpk, double ts) {
    const design::Ss s = design::zpk2ss(zpk);
    const Eigen::Index n = s.A.rows();
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n + 1, n + 1);
    m.topLeftCorner(n, n) = s.A * ts;
    m.block(0, n, n, 1) = s.B * ts;
    const Eigen::MatrixXd e = m.exp();
    design::Ss d;
    d.A = e.topLeftCorner(n, n);
    d.B = e.block(0, n, n, 1);
    d.C = s.C;
    d.D = s.D;
    d.ts = ts;
    return design::ss2zpk(d);
}

design::Zpk c2d_bilinear(const design::Zpk& zpk, double ts, double prewarp_Hz) {
    double k = 2.0 / ts;
    if (prewarp_Hz > 0.0) {
        const double w = 2.0 * M_PI * prewarp_Hz;
        k = w / std::tan(w * ts / 2.0);
    }
    design::Zpk d;
    d.ts = ts;
    design::cplx g = zpk.gain;
    for (const auto& z : zpk.zeros) {
        d.zeros.push_back((k + z) / (k - z));
        g *= (k - z);
    }
    for (const auto& p : zpk.poles) {
        d.poles.push_back((k + p) / (k - p));
        g /= (k - p);
    }
    for (size_t i = zpk.zeros.size(); i < zpk.poles.size(); ++i) d.zeros.push_back({-1.0, 0.0});
    d.gain = g.real();
    return d;
}

design::Zpk c2d_matched(const design::Zpk& zpk, double ts) {
    design::Zpk d;
    d.ts = ts;
    for (const auto& z : zpk.zeros) d.zeros.push_back(std::exp(z * ts));
    for (const auto& p : zpk.poles) d.poles.push_back(std::exp(p * ts));
    for (size_t i = zpk.zeros.size() + 1; i < zpk.poles.size(); ++i) d.zeros.push_back({-1.0, 0.0});
    // Gain matched at a low frequency where neither has a pole or zero.
    const double w = 1e-3 / ts;
    d.gain = 1.0;
    const double gc = std::abs(design::evaluate(zpk, design::frequency_point(w, 0.0)));
    const double gd = std::abs(design::evaluate(d, design::frequency_point(w, ts)));
    d.gain = gc / gd * (zpk.gain < 0.0 ? -1.0 : 1.0);
    return d;
}

// A root as a pairing unit: a conjugate pair (order 2) or a real root.
struct Unit {
    design::cplx root{};
    int order = 1;
};

std::vector<Unit> units(const std::vector<design::cplx>& roots, const char* what) {
    std::vector<double> real;
    std::vector<design::cplx> upper;
    design::split_conjugates(roots, real, upper, what);
    std::vector<Unit> out;
    for (const auto& r : upper) out.push_back({r, 2});
    for (const double r : real) out.push_back({{r, 0.0}, 1});
    return out;
}

// Monic polynomial in z of the units, as coefficients [1, c1, c2] (padded).
std::array<double, 3> poly(const std::vector<Unit>& us) {
    std::array<double, 3> c{1.0, 0.0, 0.0};
    int order = 0;
    for (const Unit& u : us) {
        if (u.order == 2) {
            c = {1.0, -2.0 * u.root.real(), std::norm(u.root)};
            order = 2;
        } else if (order == 0) {
            c = {1.0, -u.root.real(), 0.0};
            order = 1;
        } else {
            c = {1.0, c[1] - u.root.real(), -c[1] * u.root.real()};
            order = 2;
        }
    }
    return c;
}

}  // namespace

LinearSpec read_linear_model(const Field& f, const std::filesystem::path& base_dir) {
    LinearSpec s;
    s.path = f.path();
    if (f.is_string()) {
        const std::filesystem::path p = base_dir / f.string();
        std::ifstream in(p);
        if (!in) f.fail("cannot open model file " + p.string());
        nlohmann::json j;
        try {
            j = nlohmann::json::parse(in);
        } catch (const nlohmann::json::parse_error& e) {
            f.fail("model file " + p.string() + " is not valid JSON: " + e.what());
        }
        try {
            s.zpk = parse_model(Field(j, ""));
        } catch (const ScenarioError& e) {
            f.fail(std::string("model file ") + p.filename().string() + ": " + e.what());
        }
        s.source = f.string();
    } else {
        s.zpk = parse_model(f);
        s.source = "inline";
    }
    return s;
}

design::Zpk normalise_dc_gain(const design::Zpk& zpk, const Field& f) {
    const double g = design::dc_gain(zpk);
    if (!std::isfinite(g) || g == 0.0) f.fail("cannot normalise the DC gain: the model has a pole or zero at DC");
    design::Zpk z = zpk;
    z.gain /= g;
    return z;
}

std::vector<SosSection> discretise_sos(const design::Zpk& zpk, double rate_Hz, const std::string& method,
                                       double prewarp_Hz, bool advance, const std::string& what,
                                       size_t max_sections) {
    const double ts = 1.0 / rate_Hz;
    design::Zpk d;
    try {
        if (method == "zoh") d = c2d_zoh(zpk, ts);
        else if (method == "matched") d = c2d_matched(zpk, ts);
        else d = c2d_bilinear(zpk, ts, prewarp_Hz);
        if (advance) d = add_zero_at_origin(d);
    } catch (const std::exception& e) {
        throw std::invalid_argument(what + ": " + e.what());
    }
    if (d.zeros.size() > d.poles.size())
        throw std::invalid_argument(what + ": improper after discretisation");
    // Sections: every conjugate pole pair, and every real pole on its own
    // while the section budget allows (a slow real pole paired with another
    // makes 1 + a1 + a2 tiny, which float coefficients cannot resolve);
    // beyond it, the real poles farthest from the unit circle share.
    std::vector<Unit> pu = units(d.poles, "poles"), zu = units(d.zeros, "zeros");
    std::vector<std::vector<Unit>> sections;
    std::vector<Unit> reals;
    for (const Unit& u : pu) {
        if (u.order == 2) sections.push_back({u});
        else reals.push_back(u);
    }
    // Farthest from the unit circle first: those are the ones to pair.
    std::sort(reals.begin(), reals.end(),
              [](const Unit& a, const Unit& b) { return std::abs(a.root) < std::abs(b.root); });
    size_t zero_pairs = 0;
    for (const Unit& u : zu) zero_pairs += u.order == 2 ? 1 : 0;
    size_t second_order = sections.size();
    size_t i = 0;
    while (i < reals.size()) {
        const size_t left = reals.size() - i;
        const bool over_budget = sections.size() + left > max_sections;
        const bool zeros_need_room = second_order < zero_pairs;
        if ((over_budget || zeros_need_room) && i + 1 < reals.size()) {
            sections.push_back({reals[i], reals[i + 1]});
            ++second_order;
            i += 2;
        } else {
            sections.push_back({reals[i]});
            ++i;
        }
    }
    // Zeros: sections with poles nearest the unit circle choose first, each
    // taking the nearest zeros its order allows.
    std::sort(sections.begin(), sections.end(), [](const auto& a, const auto& b) {
        double ra = 0.0, rb = 0.0;
        for (const Unit& u : a) ra = std::max(ra, std::abs(u.root));
        for (const Unit& u : b) rb = std::max(rb, std::abs(u.root));
        return ra > rb;
    });
    // Complex zero pairs need second-order sections: they are placed first,
    // then the real zeros fill the remaining orders.
    std::vector<bool> used(zu.size(), false);
    std::vector<std::vector<Unit>> zeros_of(sections.size());
    std::vector<int> budget(sections.size(), 0);
    for (size_t k = 0; k < sections.size(); ++k)
        for (const Unit& u : sections[k]) budget[k] += u.order;
    for (const int pass_order : {2, 1}) {
        for (size_t k = 0; k < sections.size(); ++k) {
            const design::cplx at = sections[k].front().root;
            for (;;) {
                int best = -1;
                double best_d = 0.0;
                for (size_t q = 0; q < zu.size(); ++q) {
                    if (used[q] || zu[q].order != pass_order || zu[q].order > budget[k]) continue;
                    const double dist = std::abs(zu[q].root - at);
                    if (best < 0 || dist < best_d) {
                        best = static_cast<int>(q);
                        best_d = dist;
                    }
                }
                if (best < 0) break;
                used[static_cast<size_t>(best)] = true;
                zeros_of[k].push_back(zu[static_cast<size_t>(best)]);
                budget[k] -= pass_order;
                if (pass_order == 2) break;  // one pair per section
            }
        }
    }
    std::vector<SosSection> out;
    for (size_t k = 0; k < sections.size(); ++k) {
        const std::vector<Unit>& sec = sections[k];
        const std::vector<Unit>& zeros = zeros_of[k];
        int p_order = 0, z_order = 0;
        for (const Unit& u : sec) p_order += u.order;
        for (const Unit& u : zeros) z_order += u.order;
        const std::array<double, 3> a = poly(sec), b = poly(zeros);
        // H = z^-(p-q) B(z^-1-form): shift the numerator by the order gap.
        SosSection s{};
        s.a1 = a[1];
        s.a2 = p_order == 2 ? a[2] : 0.0;
        double num[3] = {0.0, 0.0, 0.0};
        const int shift = p_order - z_order;
        for (int q = 0; q <= z_order; ++q) num[q + shift] = b[static_cast<size_t>(q)];
        s.b0 = num[0];
        s.b1 = num[1];
        s.b2 = num[2];
        out.push_back(s);
    }
    for (size_t k = 0; k < zu.size(); ++k)
        if (!used[k]) throw std::invalid_argument(what + ": could not pair every zero with a pole");
    if (out.empty()) out.push_back(SosSection{1.0, 0.0, 0.0, 0.0, 0.0});
    // Sections nearest the unit circle last (scipy's order).
    std::reverse(out.begin(), out.end());
    // The gain: in the first section.
    out.front().b0 *= d.gain;
    out.front().b1 *= d.gain;
    out.front().b2 *= d.gain;
    return out;
}

design::Ss state_space(const design::Zpk& zpk) { return design::balance(design::zpk2ss(zpk)); }

}  // namespace piezoloop::sim
