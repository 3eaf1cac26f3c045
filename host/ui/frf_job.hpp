// The console's frequency-response measurement: the form's request checked
// and planned as `piezoloop --device ADDR measure frf` plans it, the run on
// the board in a worker thread (BoardSession::measure_frf), its progress,
// and the result every page is sent: per line the frequency, the response,
// its magnitude (dB) and unwrapped phase (deg), the magnitude's standard
// deviation (dB), and optionally a model fitted to the lines by
// measure/tf_fit (Sanathanan–Koerner, `identify tf --order N/M`).
#pragma once

#include <complex>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "measure/frf_plan.hpp"
#include "ui/board_session.hpp"
#include "ui/field_refusal.hpp"
#include "ui/measurement_job.hpp"

namespace piezoloop::ui {

// The form: {from_Hz, to_Hz, amplitude_V, bias_V, periods, transient_periods,
// signal, mode: "open"|"closed", restart_stage, fit_order: "N/M" or ""}.
struct FrfForm {
    measure::FrfRequest request;
    bool restart_stage = false;
    int fit_poles = 0, fit_zeros = 0;  // 0 poles: no fit
    std::string axis;                  // a board of axes: the measured axis (x, y, z)
};
FrfForm parse_frf_form(const nlohmann::json& j);

// The phases of g in degrees, unwrapped along the lines from the first (as
// numpy.unwrap: a step of more than 180 degrees between neighbours is taken
// as a turn).
std::vector<double> unwrapped_phase_deg(const std::vector<std::complex<double>>& g);

// A plan's refusal ("--to-hz: must be below ...") with the form's names for
// the options ("to_Hz: must be below ..."), at the field it names first.
FieldRefusal form_refusal(const std::string& plan_message);

class FrfJob {
public:
    explicit FrfJob(BoardSession& board) : board_(board) {}

    // Checks and plans the request before anything moves (FieldRefusal),
    // then starts it; BoardBusy while one runs.
    nlohmann::json start(const nlohmann::json& form);
    void request_stop() { job_.request_stop(); }
    void shutdown() { job_.shutdown(); }  // stops a running measurement and waits for it

    // As MeasurementJob's: {state, phase, fraction, request, log, error},
    // sent at every change, and the last result (null before the first).
    nlohmann::json progress_json() const { return job_.progress_json(); }
    uint64_t progress_serial() const { return job_.progress_serial(); }
    nlohmann::json result_json() const { return job_.result_json(); }
    uint64_t result_serial() const { return job_.result_serial(); }
    // The result's lines as CSV (frequency_Hz, magnitude_dB, phase_deg,
    // std_dB, re, im, and the fit's magnitude and phase); "" before the first.
    std::string result_csv() const;

private:
    BoardSession& board_;
    MeasurementJob job_{"a frequency response measurement"};
};

}  // namespace piezoloop::ui
