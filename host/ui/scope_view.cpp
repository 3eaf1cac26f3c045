#include "ui/scope_view.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "ui/min_max_columns.hpp"

namespace piezoloop::ui {

using nlohmann::json;

namespace {

double number_in(const json& v, const std::string& key, double lo, double hi) {
    if (!v.is_number()) throw std::invalid_argument("scope." + key + ": must be a number");
    const double x = v.get<double>();
    if (!(x >= lo && x <= hi))
        throw std::invalid_argument("scope." + key + ": " + std::to_string(x) + " is outside [" + std::to_string(lo) +
                                    ", " + std::to_string(hi) + "]");
    return x;
}

std::string text(const json& v, const std::string& key) {
    if (!v.is_string()) throw std::invalid_argument("scope." + key + ": must be a string");
    return v.get<std::string>();
}

}  // namespace

ScopeSettings merge_scope_settings(const json& j, const ScopeSettings& s, const SampleHistory& h) {
    if (!j.is_object()) throw std::invalid_argument("scope: must be an object");
    ScopeSettings out = s;
    for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string& k = it.key();
        if (k == "mode") {
            const std::string m = text(*it, k);
            if (m != "roll" && m != "triggered") throw std::invalid_argument("scope.mode: roll or triggered, not '" + m + "'");
            out.triggered = m == "triggered";
        } else if (k == "span_s") {
            out.span_s = number_in(*it, k, 1e-4, 60.0);
        } else if (k == "columns") {
            out.columns = static_cast<std::size_t>(number_in(*it, k, 16, 8192));
        } else if (k == "trigger_signal") {
            const std::string name = text(*it, k);
            if (!h.find(name)) throw std::invalid_argument("scope.trigger_signal: '" + name + "' is not a recorded signal");
            out.trigger_signal = name;
        } else if (k == "trigger_level") {
            out.trigger_level = number_in(*it, k, -1e9, 1e9);
        } else if (k == "edge") {
            const std::string e = text(*it, k);
            if (e != "rising" && e != "falling") throw std::invalid_argument("scope.edge: rising or falling, not '" + e + "'");
            out.rising = e == "rising";
        } else if (k == "trigger_fraction") {
            out.trigger_fraction = number_in(*it, k, 0.0, 0.9);
        } else {
            throw std::invalid_argument("scope." + k + ": unknown setting (mode, span_s, columns, trigger_signal, "
                                        "trigger_level, edge, trigger_fraction)");
        }
    }
    return out;
}

json to_json(const ScopeSettings& s) {
    return {{"mode", s.triggered ? "triggered" : "roll"}, {"span_s", s.span_s},
            {"columns", s.columns}, {"trigger_signal", s.trigger_signal},
            {"trigger_level", s.trigger_level}, {"edge", s.rising ? "rising" : "falling"},
            {"trigger_fraction", s.trigger_fraction}};
}

std::string base64_float32(const std::vector<float>& v) {
    static const char* const kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::vector<unsigned char> bytes(v.size() * 4);
    for (std::size_t i = 0; i < v.size(); ++i) {
        uint32_t u = 0;
        std::memcpy(&u, &v[i], 4);
        for (int b = 0; b < 4; ++b) bytes[4 * i + b] = static_cast<unsigned char>(u >> (8 * b));
    }
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    for (std::size_t i = 0; i < bytes.size(); i += 3) {
        const uint32_t n = (uint32_t{bytes[i]} << 16) | (i + 1 < bytes.size() ? uint32_t{bytes[i + 1]} << 8 : 0) |
                           (i + 2 < bytes.size() ? uint32_t{bytes[i + 2]} : 0);
        out += kAlphabet[(n >> 18) & 63];
        out += kAlphabet[(n >> 12) & 63];
        out += i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=';
        out += i + 2 < bytes.size() ? kAlphabet[n & 63] : '=';
    }
    return out;
}

std::optional<json> ScopeView::next_frame(const SampleHistory& h, const ScopeSettings& s, int64_t now_ms) {
    const std::optional<double> end = h.end_s();
    if (!end) return std::nullopt;
    const std::string settings = to_json(s).dump();
    const bool changed = settings != last_settings_;
    if (changed) trigger_t_s_.reset();
    if (!changed && *end == last_end_s_) return std::nullopt;
    last_settings_ = settings;
    last_end_s_ = *end;

    double t0 = *end - s.span_s;
    bool waiting = false;
    if (s.triggered) {
        Trigger trig;
        // The channels changed under the settings: no trigger until the
        // page picks one of the new signals.
        const std::optional<std::size_t> k = h.find(s.trigger_signal);
        if (!k) return std::nullopt;
        trig.signal = *k;
        trig.level = s.trigger_level;
        trig.rising = s.rising;
        // The crossing must leave room for the rest of the window after it.
        const double latest = *end - (1.0 - s.trigger_fraction) * s.span_s;
        const std::optional<double> crossing = h.last_crossing(trig, latest, 10.0 * s.span_s);
        if (crossing && crossing != trigger_t_s_) {
            trigger_t_s_ = crossing;
        } else {
            waiting = true;
            if (!trigger_t_s_) return std::nullopt;
            if (!changed && crossing == trigger_t_s_) return std::nullopt;  // the same trace again
        }
        t0 = *trigger_t_s_ - s.trigger_fraction * s.span_s;
    }
    const SampleWindow w = h.window(t0, s.span_s);
    json series = json::object();
    for (std::size_t k = 0; k < w.signals.size(); ++k) {
        const ColumnPoints p = min_max_columns(w.t_s, w.values[k], t0, s.span_s, s.columns);
        std::vector<float> interleaved(2 * s.columns);
        for (std::size_t c = 0; c < s.columns; ++c) {
            interleaved[2 * c] = p.first[c];
            interleaved[2 * c + 1] = p.second[c];
        }
        series[w.signals[k].name] = base64_float32(interleaved);
    }
    json units = json::object();
    for (const Signal& sig : w.signals) units[sig.name] = sig.unit;
    ++seq_;
    return json{{"seq", seq_},
                {"t0_s", t0},
                {"span_s", s.span_s},
                {"columns", s.columns},
                {"mode", s.triggered ? "triggered" : "roll"},
                {"trigger_t_s", s.triggered && trigger_t_s_ ? json(*trigger_t_s_) : json(nullptr)},
                {"waiting", waiting},
                {"samples", w.t_s.size()},
                {"newest_arrival_ms", w.newest_arrival_ms},
                {"sent_ms", now_ms},
                {"units", units},
                {"series", series}};
}

std::string window_csv(const SampleHistory& h, double t0_s, double span_s) {
    const SampleWindow w = h.window(t0_s, span_s);
    std::string out = "t_s";
    for (const Signal& s : w.signals) out += "," + s.name + "_" + s.unit;
    out += "\n";
    char buf[40];
    for (std::size_t i = 0; i < w.t_s.size(); ++i) {
        std::snprintf(buf, sizeof buf, "%.17g", w.t_s[i]);
        out += buf;
        for (const auto& col : w.values) {
            std::snprintf(buf, sizeof buf, ",%.9g", static_cast<double>(col[i]));
            out += buf;
        }
        out += "\n";
    }
    return out;
}

nlohmann::json cursor_sample(const SampleHistory& h, double t_s) {
    const double tick = 1.0 / h.rate_Hz();
    const SampleWindow w = h.window(t_s - tick, 2.0 * tick + tick / 2);
    std::optional<std::size_t> best;
    for (std::size_t i = 0; i < w.t_s.size(); ++i)
        if (!best || std::abs(w.t_s[i] - t_s) < std::abs(w.t_s[*best] - t_s)) best = i;
    if (!best || std::abs(w.t_s[*best] - t_s) > tick) return {{"t_s", nullptr}};
    nlohmann::json values = nlohmann::json::object();
    for (std::size_t k = 0; k < w.signals.size(); ++k) {
        const float v = w.values[k][*best];
        values[w.signals[k].name] = std::isfinite(v) ? nlohmann::json(static_cast<double>(v)) : nlohmann::json(nullptr);
    }
    return {{"t_s", w.t_s[*best]}, {"values", values}};
}

}  // namespace piezoloop::ui
