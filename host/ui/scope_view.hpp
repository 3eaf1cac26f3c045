// One page's scope: its settings (time base, roll or triggered, the
// trigger) and the frames its stream sends: the window's samples decimated
// to min/max per pixel column (ui/min_max_columns), per signal by name.
//   roll:      the newest span_s of the record, moving left as it grows;
//   triggered: the window around the latest crossing of the trigger level
//              by the trigger signal (rising or falling), the crossing at
//              trigger_fraction of the width; until the next crossing the
//              last triggered window stays (a scope's normal mode).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "ui/sample_history.hpp"

namespace piezoloop::ui {

struct ScopeSettings {
    bool triggered = false;
    double span_s = 0.1;          // time base: the window's width
    std::size_t columns = 800;    // pixel columns of the plot
    std::string trigger_signal = "r";
    double trigger_level = 0.0;   // in the trigger signal's unit
    bool rising = true;
    double trigger_fraction = 0.1;
};

// Merges the keys of j (mode "roll" | "triggered", span_s, columns,
// trigger_signal, trigger_level, edge "rising" | "falling",
// trigger_fraction) onto s; std::invalid_argument naming the key and its
// range for anything else, s unchanged then.
ScopeSettings merge_scope_settings(const nlohmann::json& j, const ScopeSettings& s, const SampleHistory& h);
nlohmann::json to_json(const ScopeSettings& s);

// Little-endian float32 values as base64 (the frames' series: exact values,
// NaN kept, a quarter of the size of decimal text).
std::string base64_float32(const std::vector<float>& v);

class ScopeView {
public:
    // The next frame for the settings, or nullopt when there is nothing new
    // to show (no new samples since the last frame, or no trigger yet).
    // Frame: seq, t0_s, span_s, columns, mode, waiting (no new trigger),
    // samples (in the window), newest_arrival_ms (host clock, ms),
    // sent_ms, and series {name: base64 float32 [first0, second0, first1, ...]}.
    std::optional<nlohmann::json> next_frame(const SampleHistory& h, const ScopeSettings& s, int64_t now_ms);
    uint64_t last_seq() const { return seq_; }  // of the last frame made

private:
    uint64_t seq_ = 0;
    double last_end_s_ = -1.0;
    std::optional<double> trigger_t_s_;
    std::string last_settings_;
};

// The samples of [t0_s, t0_s + span_s) as CSV: t_s and one column per
// signal with its unit, values as the board's floats (9 significant digits:
// every float32 survives the round trip).
std::string window_csv(const SampleHistory& h, double t0_s, double span_s);

// A cursor at t_s: the recorded sample nearest it within one tick, {t_s, values: {name: value}} (the board's floats,
// null where a signal was not recorded); {t_s: null} without one.
nlohmann::json cursor_sample(const SampleHistory& h, double t_s);

}  // namespace piezoloop::ui
