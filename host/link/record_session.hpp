// A record session with a board: configure the recorder (and optionally the
// reference wave), collect the log blocks for a duration of device time,
// stop, and turn the record into a CSV file, the log hash of `piezoloop sim
// --hash` and the tracking figures of its last reference period. Used by
// `piezoloop record`; callable from any client of the host link library.
//
// A record that ends early (the link fails, the board stops sending, the
// caller asks to stop, e.g. on Ctrl-C) keeps what arrived: the CSV holds
// those frames under a "# incomplete: ..." comment, and the result says why.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "link/client.hpp"

namespace piezoloop::hostlink {

// "r,y,e,u" as signal ids, in order (std::invalid_argument naming --signals
// for an unknown or repeated name, or an empty list).
std::vector<uint8_t> parse_signal_list(const std::string& list);

struct RecordOptions {
    std::vector<uint8_t> signals;                // recorded and written, in this order
    uint8_t axis = 0;                            // the axis of the signals, the wave and the excitation
    // Per signal, its axis when signals of several axes are recorded (empty:
    // every signal is `axis`'s). Such a record has no log hash and no
    // tracking figures; its CSV columns name the axis (y_y_um).
    std::vector<uint8_t> signal_axes;
    double duration_s = 0.0;                     // device time
    uint32_t decimation = 1;                     // keep every N-th tick
    std::optional<link::TrajectoryParams> wave;  // set before recording (not started)
    bool start_wave = false;      // start the wave with the recorder (and the loop, if disarmed)
    // With start_wave on a board of axes: every axis's wave (its trajectory
    // group as set) from the same tick, not only `axis`'s.
    bool every_axis = false;
    // Instead of a wave: start this excitation with the recorder (and the
    // loop, if disarmed) at one tick; the setpoint holds.
    std::optional<ExcitationConfig> excitation;
    bool restart_stage = false;   // with start_wave or excitation: emulated stage and loop from rest
    double stall_s = 5.0;         // give up when no frames arrive for this long
    std::string out_csv;          // CSV file to write; empty: none
    std::function<bool()> stop_requested;      // polled while collecting (e.g. set by SIGINT)
    std::function<void(double)> progress;      // fraction of the record received
};

struct RecordFigures {
    std::string window;          // "last reference period" or "whole record"
    std::size_t window_start = 0;
    std::size_t window_frames = 0;
    double hysteresis_pct = -1.0;  // < 0: not defined
    double e_max_pct = 0, e_rms_pct = 0, e_max_um = 0, e_rms_um = 0, e_pp_um = 0, range_um = 0;
};

struct RecordResult {
    std::string device, board;
    double rate_Hz = 0.0;
    std::vector<uint8_t> signals;
    std::vector<uint8_t> signal_axes;  // RecordOptions::signal_axes
    uint32_t decimation = 1;
    double stall_s = 0.0;
    std::size_t frames = 0, expected_frames = 0;
    LogStats log;
    ClientCounters client;
    uint64_t host_link_dropped = 0;
    std::optional<uint32_t> tick_overruns;  // unknown when the board was lost
    bool stalled = false, interrupted = false;
    std::string link_error;                 // the failure that ended the record early
    std::vector<std::string> notes;
    bool wave_running = false;
    link::TrajectoryParams wave;
    // Ticks of the started wave's approach before its first point
    // (common/piezoloop/approach.hpp), added to the record's length so that
    // it covers duration_s of the wave itself.
    uint64_t approach_ticks = 0;
    std::optional<uint64_t> log_hash;       // needs r, y and u
    std::optional<RecordFigures> figures;   // needs r and y
    // The record in physical units: t_s and one column per signal.
    std::vector<double> t_s;
    std::vector<std::vector<double>> values;

    // Why the record is incomplete ("" when it is complete).
    std::string problems() const;
    bool complete() const { return problems().empty(); }
};

// Runs the session on a client that has said hello. Throws
// std::invalid_argument for options the board cannot take and LinkError for
// a failure before recording starts; a failure after that ends the record
// early (result.link_error) instead. The CSV (out_csv) is written through a
// temporary file renamed at the end.
RecordResult record(Client& c, const RecordOptions& o);

// The summary `piezoloop record` prints (counts, hash, figures, and
// "complete"/"incomplete").
nlohmann::json summary_json(const RecordResult& r);

// What tools/plot_sim.py draws of a record with r, y and u (empty JSON
// otherwise): time series and the figures' window.
nlohmann::json plot_spec(const RecordResult& r, const std::string& png);

}  // namespace piezoloop::hostlink
