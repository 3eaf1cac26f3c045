#include "link/board_stage.hpp"

#include <utility>

#include "link/record_session.hpp"
#include "sim/design_bridge.hpp"

namespace piezoloop::hostlink {

std::string BoardStage::describe() const {
    const link::HelloReply& h = c_.info();
    return "board " + std::string(h.board.data()) + " (firmware " + std::string(h.firmware_version.data()) + ") at " +
           c_.address();
}

namespace {

// An axis's full scales (a single-axis board's own).
std::pair<double, double> full_scales(const link::HelloReply& h, uint8_t axis) {
    if (h.axis_count > 1 && axis < link::kMaxLinkAxes)
        return {h.axis_position_full_scale_um[axis], h.axis_voltage_full_scale_V[axis]};
    return {h.position_full_scale_um, h.voltage_full_scale_V};
}

}  // namespace

commission::LoopFacts BoardStage::loop() {
    const link::HelloReply& h = c_.info();
    const auto [position_um, voltage_V] = full_scales(h, o_.axis);
    return {h.loop_rate_Hz, h.sample_format == link::SampleFormat::kQ31, position_um, voltage_V};
}

link::FeedbackParams feedback_group(const design::Zpk& controller, const link::HelloReply& h, bool series,
                                    uint8_t axis) {
    const auto [position_um, voltage_V] = full_scales(h, axis);
    const std::vector<SosSection> sos =
        sim::controller_sos(controller, h.loop_rate_Hz, "tustin", 0.0, h.sample_format == link::SampleFormat::kQ31,
                            position_um, series ? position_um : voltage_V, "controller");
    if (sos.size() > h.max_sos_sections)
        throw std::invalid_argument("controller: " + std::to_string(sos.size()) + " biquad sections, this board runs " +
                                    std::to_string(h.max_sos_sections));
    link::FeedbackParams g;
    g.kind = FeedbackKind::kSos;
    g.sos_count = static_cast<int>(sos.size());
    for (std::size_t i = 0; i < sos.size(); ++i) g.sos[i] = sos[i];
    return g;
}

commission::TrackingRun BoardStage::track(const commission::Controller& k, const commission::TrackRequest& t) {
    const link::HelloReply& h = c_.info();
    const uint8_t a = o_.axis;
    const link::FeedbackParams fb = feedback_group(k.feedback, h, k.series, a);
    const double position_um = full_scales(h, a).first;
    link::FeedforwardParams ff;
    if (k.feedforward) {
        ff.kind = k.series ? FeedforwardKind::kPiSeries : FeedforwardKind::kPiCompensator;
        ff.pi = *k.feedforward;
    }
    if (k.prefilter) {
        const std::vector<SosSection> pf =
            sim::controller_sos(*k.prefilter, h.loop_rate_Hz, "tustin", 0.0, h.sample_format == link::SampleFormat::kQ31,
                                position_um, position_um, "prefilter", kMaxPrefilterSections);
        ff.prefilter_count = static_cast<int>(pf.size());
        for (std::size_t i = 0; i < pf.size(); ++i) ff.prefilter[i] = pf[i];
    }
    link::StatusReply st = c_.status();
    if (st.axis_wave_running[a]) c_.stop_wave(a);
    if (st.armed) c_.disarm();
    for (std::size_t i = 0; i < st.axis_count && i < link::kMaxLinkAxes; ++i)
        if (st.axis_tripped[i])
            throw std::runtime_error(std::string("the board's limiter is tripped (") +
                                     trip_reason_name(static_cast<TripReason>(st.axis_trip_reason[i])) + ")" +
                                     (st.axis_count > 1 ? " on axis " + std::to_string(i) : std::string()));
    // RC off before the feedback changes (it needs one).
    // The feedback before the feedforward: a compensator in series needs a
    // feedback to follow.
    c_.set(link::RepetitiveParams{}, a);
    c_.set(fb, a);
    c_.set(ff, a);
    link::TrajectoryParams w;
    w.waveform = Waveform::kTriangle;
    w.amplitude_um = static_cast<float>(0.5 * t.range_um);
    w.offset_um = static_cast<float>(t.centre_um);
    w.frequency_Hz = static_cast<float>(t.frequency_Hz);
    w.start_phase_cycles = 0.0f;  // from the triangle's minimum
    // Two periods and done: the board runs exactly the recorded window and
    // stops by itself at the triangle's minimum, instead of running on for
    // as long as the host takes to stop it and holding wherever that was.
    // (The next run starts from the stage's reading either way: the core
    // settles the pre-filter there when a wave's approach starts.)
    w.cycles = 2;
    RecordOptions ro;
    ro.signals = {signal_index(SignalId::kR), signal_index(SignalId::kY), signal_index(SignalId::kE),
                  signal_index(SignalId::kU)};
    ro.duration_s = 2.0 / t.frequency_Hz;  // the second period is the window
    ro.wave = w;
    ro.axis = a;
    ro.start_wave = true;
    ro.stop_requested = o_.stop_requested;
    ro.progress = o_.progress;
    const RecordResult rec = record(c_, ro);
    st = c_.status();
    if (st.axis_wave_running[a]) c_.stop_wave(a);
    c_.disarm();
    if (!rec.complete()) throw LinkError("the recording is incomplete:" + rec.problems());
    if (!rec.figures) throw LinkError("the recording has no tracking figures");
    commission::TrackingRun out;
    out.e_max_um = rec.figures->e_max_um;
    out.e_rms_um = rec.figures->e_rms_um;
    out.e_max_pct = rec.figures->e_max_pct;
    out.e_rms_pct = rec.figures->e_rms_pct;
    out.hysteresis_pct = rec.figures->hysteresis_pct;
    out.trip = trip_reason_name(static_cast<TripReason>(st.axis_trip_reason[a]));
    const measure::MeasureBounds mb = bounds();
    out.diagnosis_inputs = {h.loop_rate_Hz, t.frequency_Hz, t.range_um, mb.limits.u_min_V, mb.limits.u_max_V,
                            mb.closed_range.min_um, mb.closed_range.max_um};
    if (rec.values.size() == 4)  // r, y, e, u as asked
        out.diagnosis = commission::diagnose_tracking(rec.values[0], rec.values[1], rec.values[3], out.diagnosis_inputs);
    return out;
}

}  // namespace piezoloop::hostlink
