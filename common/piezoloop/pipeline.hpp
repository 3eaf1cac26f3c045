// The control pipeline: one tick of docs/architecture.md, "Data flow of one tick".
//
//   r    <- wave generator (after its approach), or the held / streamed setpoint
//   r    <- reference pre-filter of r (biquad sections; none by default)
//   u_ff <- inverse hysteresis of r (analytic PI inverse, a PI compensator
//           such as Shan2012's fitted inverse, or Dahl feedforward)
//   e     = r - y;  e' = e + RC(e) when repetitive control is on (RC's
//           correction depends only on past errors: computed before y)
//   u_fb <- feedback of e' (biquad cascade with anti-windup, anti_windup.hpp; or PID)
//   u     = limits(u_ff + u_fb)  -> DAC
//   recorder <- (r, y, e, u, u_ff, u_fb, u_rc)
//
// Excitation (excitation.hpp): while one runs, its sample d is
// added to r after the wave (ExcitationPoint::kReference) or to the command
// before the limiter (kCommand: u = limits(u_ff + u_fb + d); open loop, with
// no feedforward and no feedback, u = limits(d) and d carries the bias). The
// limiter still acts last; the samples it clamped or slew-limited while the
// excitation ran are counted. Its first samples blend from where the
// reference or the command was into d (lead_in.hpp), so it starts without
// a jump. Without an excitation the tick pays one
// well-predicted branch per phase and its arithmetic is unchanged (the log
// hashes do not move).
//
// Approach (approach.hpp): a wave starts with a minimum-jerk move of r,
// at most kApproachFullScalesPerSecond full scales per second, from the
// reference the loop tracks (the held setpoint, when the loop was armed
// before the wave's first tick) or else from the stage's latest reading,
// to the wave's first value; the wave's clock starts when it ends. A
// distance the speed bound allows within one tick (zero included) takes no
// tick: the wave starts at once, with the arithmetic it always had. While
// a wave runs the tick pays one well-predicted branch for it.
//
// Reference pre-filter: up to two sections on the reference, so
// that its corners and steps do not excite the stage's lightly damped modes
// through the feedforward (notches at the modes). It runs every tick, armed
// or not, so it has settled on the reference when the loop arms; r as
// recorded and tracked is the filtered one. A wave that starts from the
// stage's reading (its approach, above) first puts the pre-filter at its
// steady state for that reading (BiquadCascade::settle), so the filtered r
// starts where the stage is, not at the setpoint held before. A changed
// pre-filter starts from rest, so it changes only while disarmed (stage()
// refuses it while armed).
// Without one the tick pays one well-predicted branch and its arithmetic is
// unchanged.
//
// Series placement (FeedforwardKind::kPiSeries, Shan2012's structure): the
// compensator follows the controller instead of adding to it,
//   u_fb <- feedback of e' (a displacement correction, µm)
//   u_ff  = P^-1(r + u_fb)       (V; recorded as u_ff)
//   u     = limits(u_ff)  -> DAC
// so the feedback loop and the RC see P(P^-1(.)) ~ identity instead of the
// hysteresis' local slope. The limiter stays last, in volts, for every kind:
// the hard limits protect the piezo whatever the placement.
//
// What the hardware fixes (loop rate, converter full scales, hard output
// limits) is the PipelineSetup, given once at construction. What users tune is
// the PipelineParams: validated field by field, configured into the inactive
// one of two banks outside the tick, and swapped in at the next tick boundary.
// A rejected set changes nothing. At the swap, every block whose parameters
// did not change carries its state over (so retuning the feedback does not
// reset the feedforward's play operators, and changing limits resets
// nothing); changed blocks start from rest. While armed, a set that changes
// the repetitive controller waits for the RC's period boundary (docs/models.md, 'Repetitive control').
// The limiter is not banked: it carries the last output across a swap so the
// piezo never sees a jump beyond the slew limit, and its hard limits cannot
// be changed by any parameter set.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "piezoloop/approach.hpp"
#include "piezoloop/biquad.hpp"
#include "piezoloop/dahl.hpp"
#include "piezoloop/excitation.hpp"
#include "piezoloop/anti_windup.hpp"
#include "piezoloop/lead_in.hpp"
#include "piezoloop/limits.hpp"
#include "piezoloop/pi_inverse.hpp"
#include "piezoloop/pi_model.hpp"
#include "piezoloop/pi_start_state.hpp"
#include "piezoloop/pid.hpp"
#include "piezoloop/recorder.hpp"
#include "piezoloop/repetitive.hpp"
#include "piezoloop/sample.hpp"
#include "piezoloop/status.hpp"
#include "piezoloop/trajectory.hpp"

namespace piezoloop {

inline constexpr int kMaxControllerSections = 4;
inline constexpr int kMaxPrefilterSections = 2;
inline constexpr char kPrefilterName[] = "prefilter";  // its sections' field names: "prefilter[i].b0"

enum class FeedforwardKind : uint8_t {
    kNone = 0,
    kPiInverse,      // `pi` is the stage's model (V -> µm); its analytic inverse runs
    kPiCompensator,  // `pi` is the compensator itself (µm -> V), e.g. Shan2012's inverse
    kDahl,           // inversion-free Dahl feedforward (float arithmetic in both pipelines)
    kPiSeries,       // `pi` is the compensator (µm -> V) in series after the feedback:
                     // u = limits(pi(r + u_fb)), the feedback's output in µm (Shan2012)
};

enum class FeedbackKind : uint8_t { kNone = 0, kSos, kPid };

struct PipelineSetup {
    HardLimits hard{};            // the piezo's and amplifier's limits: never exceeded
    float rate_Hz = 100000.0f;    // loop rate
    SignalScale position{40.0f};  // r, y, e: µm at Q31 full scale
    SignalScale voltage{150.0f};  // u: V at Q31 full scale
};

struct PipelineParams {
    FeedforwardKind feedforward = FeedforwardKind::kNone;
    PiModel pi{};
    DahlParams dahl{};
    FeedbackKind feedback = FeedbackKind::kNone;
    // Feedback e (µm) -> u_fb (V); with kPiSeries, e (µm) -> u_fb (µm): a
    // correction of the displacement command (the PID's u_min/u_max in µm).
    int sos_count = 0;  // feedback sections, discrete at the loop rate
    std::array<SosSection, kMaxControllerSections> sos{};
    PidConfig pid{};
    bool rc_enabled = false;
    RepetitiveConfig rc{};
    LimitsConfig limits{};
    // Reference pre-filter r (µm) -> r (µm), discrete at the loop rate; 0: none.
    int prefilter_count = 0;
    std::array<SosSection, kMaxPrefilterSections> prefilter{};
};

// Everything the tick computes, in sample units (µm and V for float).
template <class T>
struct TickSignals {
    T r{}, y{}, e{}, u{}, u_ff{}, u_fb{}, u_rc{};
    T d{};  // the excitation's sample (zero when none runs)
};

template <class T, int RcCapacity = 1024, std::size_t RecChannels = 4, std::size_t RecCapacity = 1024,
          std::size_t ExcCapacity = 1024>
class Pipeline {
    static_assert(is_sample_type_v<T>, "Pipeline<T>: T is float or Q31");
    static constexpr bool kFloat = std::is_same_v<T, float>;

public:
    using SampleType = T;
    using RecorderType = Recorder<T, RecChannels, RecCapacity>;
    using RepetitiveType = RepetitiveController<T, RcCapacity>;
    using Trajectory = TrajectoryGenerator<T>;
    using Excitation = ExcitationGenerator<T, ExcCapacity>;

    explicit Pipeline(const PipelineSetup& setup)
        : limiter_(setup.hard, setup.rate_Hz, setup.voltage),
          trajectory_(setup.position),
          approach_(setup.position, setup.rate_Hz),
          setup_(setup) {}

    // Field-by-field check of a parameter set, without touching anything
    // (configures a scratch bank on the stack: host and main-loop use).
    Status validate(const PipelineParams& p) const {
        Bank scratch{};
        if (const Status s = configure_bank(p, scratch); !s.ok()) return s;
        typename OutputLimiter<T>::Setting limits{};
        return in_group("limits", limiter_.prepare(p.limits, limits));
    }

    // Validates p and configures the inactive bank; the tick swaps it in at
    // its next boundary. Returns an error (and changes nothing) if p is
    // invalid or a previous set is still waiting to be swapped in.
    // Main-loop context.
    Status stage(const PipelineParams& p) {
        if (swap_pending_.load(std::memory_order_acquire))
            return error("params", "previous parameter set not yet swapped in; retry after one tick");
        // Only the inactive bank is written; the tick never reads it until
        // swap_pending_ is set below.
        Bank& next = banks_[active_ ^ 1u];
        // The limiter's setting is computed here, in the main loop: the tick
        // that swaps the bank in only copies it.
        typename OutputLimiter<T>::Setting limits{};
        if (const Status s = limiter_.prepare(p.limits, limits); !s.ok()) return in_group("limits", s);
        if (const Status s = configure_bank(p, next); !s.ok()) return s;
        // A changed pre-filter starts from rest: inside a running loop that
        // would step the reference.
        const PipelineParams& running = params_[active_];
        if (armed() && (p.prefilter_count != running.prefilter_count || !(p.prefilter == running.prefilter)))
            return error("prefilter", "the reference pre-filter changes only while disarmed");
        limits_next_ = limits;
        params_[active_ ^ 1u] = p;
        rc_changes_ = p.rc_enabled != params_[active_].rc_enabled || !(p.rc == params_[active_].rc);
        swap_pending_.store(true, std::memory_order_release);
        return ok_status();
    }
    bool swap_pending() const { return swap_pending_.load(std::memory_order_acquire); }

    // Armed: the controller drives the output (its states start from rest at
    // the first armed tick). Disarmed: the output ramps, at the slew limit, to
    // the safe value. Requests from the main loop take effect at the next tick.
    // Arming is bumpless for a PI compensator (inverse, compensator, series):
    // instead of zero states it starts from those whose output at the first
    // reference is the command in effect (pi_start_state.hpp), so the command
    // does not step to the compensator's virgin-curve value.
    void arm() {
        if (!armed()) plan_arming();
        arm_as_planned();
    }
    // arm() in steps, for a board that arms with its tick masked (several
    // axes, or a start at one tick boundary): the plan with the tick running
    // (software double on a Cortex-M3: longer than a tick), then the request.
    // The plan's first reference: the stage's reading when a wave's approach
    // starts there, else the held setpoint; plan_arming_from takes it from a
    // caller that knows what the arming tick will start.
    void plan_arming() { plan_arming_from(wave_running() ? last_.y : setpoint_); }
    void plan_arming_from(T first_reference);
    void arm_as_planned() { armed_.store(true, std::memory_order_release); }
    void disarm() { armed_.store(false, std::memory_order_release); }
    bool armed() const { return armed_.load(std::memory_order_acquire); }

    // Setpoint used when no wave is running (streamed or held), µm. One
    // aligned word: safe to write from the main loop while the tick runs.
    // A non-finite setpoint is refused (and counted): the hysteresis
    // operators never see NaN.
    bool set_setpoint(T r) {
        if constexpr (kFloat) {
            if (!is_finite(r)) {
                ++rejected_setpoints_;
                return false;
            }
        }
        setpoint_ = r;
        return true;
    }
    uint32_t rejected_setpoints() const { return rejected_setpoints_; }
    // The held setpoint (a wave's last value once it ended).
    T setpoint() const { return setpoint_; }

    // The tick touches the generator only while a wave runs, so it is
    // configured here only while none does. The wave's first tick starts
    // its approach (approach.hpp), from the held setpoint if the loop is
    // armed then and was armed the tick before, else from the stage's
    // latest reading.
    Status start_wave(const TrajectoryConfig& c) {
        if (const Status s = prepare_wave(c); !s.ok()) return s;
        run_wave();
        return ok_status();
    }
    // start_wave in two steps, so a board of axes configures every axis's
    // wave before it starts any (all at one tick boundary, or none).
    Status prepare_wave(const TrajectoryConfig& c) {
        if (wave_running()) return in_group("trajectory", error("waveform", "a wave is running: stop it first"));
        if (c.sample_rate_Hz != setup_.rate_Hz)
            return in_group("trajectory", error("sample_rate_Hz", "must equal the loop rate"));
        if (const Status s = trajectory_.configure(c); !s.ok()) return in_group("trajectory", s);
        return ok_status();
    }
    void run_wave() {
        approach_.request(trajectory_.start_value());
        wave_running_.store(true, std::memory_order_release);
    }
    // Ticks the approach of a wave starting now would take from `from` (the
    // stage's reading, or the held setpoint of an armed loop) to the
    // configured wave's first value; 0 or 1: none. Main loop, after
    // start_wave (or configure trajectory() first).
    uint32_t approach_ticks(T from) const { return approach_.ticks_for(from, trajectory_.start_value()); }
    bool approaching() const { return wave_running() && approach_.active(); }
    // The stage was put back at rest (an emulated stage's restart): its next
    // reading is zero, and an approach that starts now starts there. Only
    // while the tick does not run (the device's masked section).
    void stage_restarted() { last_.y = sample_zero<T>(); }
    // Holds `r` (the stage's reading) from the next tick with the pre-filter
    // at its steady state for it, as a wave's start from the reading does:
    // for a caller that sets the setpoint each tick (a scan) starting where
    // the stage is. Only while the tick does not run (the device's masked
    // section).
    void hold_from_reading(T r) {
        setpoint_ = r;
        settle_prefilter(r);
    }
    // The setpoint holds the wave's last value.
    void stop_wave() { stop_request_.store(true, std::memory_order_release); }
    bool wave_running() const { return wave_running_.load(std::memory_order_acquire); }

    // An excitation (excitation.hpp) from the next tick on; configured here
    // only while none runs (a multisine's period is tabulated here, in the
    // main loop). Its sample rate must be the loop rate.
    Status start_excitation(const ExcitationConfig& c) {
        if (const Status s = prepare_excitation(c); !s.ok()) return s;
        run_excitation();
        return ok_status();
    }
    // start_excitation in two steps, for a board that starts other things
    // at the same tick boundary with the tick masked: prepare (validate,
    // tabulate: long, so unmasked; the tick does not read the generator
    // while none runs), then run (a flag the next tick takes).
    Status prepare_excitation(const ExcitationConfig& c) {
        if (excitation_running())
            return in_group("excitation", error("signal", "an excitation is running: stop it first"));
        if (c.sample_rate_Hz != setup_.rate_Hz)
            return in_group("excitation", error("sample_rate_Hz", "must equal the loop rate"));
        if (c.point == ExcitationPoint::kCommand) {
            if (const Status s = check_command_span(c); !s.ok()) return in_group("excitation", s);
        }
        excitation_.set_output_scale(c.point == ExcitationPoint::kReference ? setup_.position : setup_.voltage);
        if (const Status s = excitation_.configure(c); !s.ok()) return in_group("excitation", s);
        exc_to_command_ = c.point == ExcitationPoint::kCommand;
        const uint64_t period = c.signal == ExcitationSignal::kPrbs
                                    ? ((uint64_t{1} << c.prbs_order) - 1u) * c.prbs_hold
                                    : uint64_t{c.period_samples};
        lead_in_.prepare(c.point == ExcitationPoint::kReference ? setup_.position : setup_.voltage, setup_.rate_Hz,
                         period);
        exc_prepared_ = true;
        return ok_status();
    }
    // Runs the prepared excitation from the next tick (once per prepare).
    void run_excitation() {
        if (!exc_prepared_ || excitation_running()) return;
        exc_prepared_ = false;
        exc_clipped_ = 0;
        exc_ticks_ = 0;
        exc_stop_request_.store(false, std::memory_order_relaxed);
        excitation_running_.store(true, std::memory_order_release);
    }
    bool excitation_prepared() const { return exc_prepared_; }
    // d at the command must fit the limits group's range before it starts
    // (the limiter would clamp it anyway, but a measurement that clips is
    // not what was asked for). Open loop (no feedforward, no feedback: u = d)
    // the whole span of d, bias included, must lie in [u_min_V, u_max_V];
    // closed loop d adds to the controller's output, so its span must be at
    // most the range's width.
    Status check_command_span(const ExcitationConfig& c) const {
        // The set in effect at the excitation's first tick: a staged one
        // swaps in before it.
        const PipelineParams& p = swap_pending() ? params_[active_ ^ 1u] : params_[active_];
        const LimitsConfig& lim = p.limits;
        // The span below needs both finite; the generator's own check comes
        // after this one, so a NaN is named here as what it is.
        if (!is_finite(c.offset)) return error("offset", "must be finite");
        if (!is_finite(c.amplitude)) return error("amplitude", "must be finite");
        const bool unipolar = c.signal == ExcitationSignal::kStep || c.signal == ExcitationSignal::kTriangle ||
                              c.signal == ExcitationSignal::kRaisedCosine;
        const float a = c.amplitude < 0.0f ? -c.amplitude : c.amplitude;
        const float lo = unipolar ? (c.amplitude < 0.0f ? c.offset - a : c.offset) : c.offset - a;
        const float hi = unipolar ? (c.amplitude < 0.0f ? c.offset : c.offset + a) : c.offset + a;
        if (!(lim.u_max_V > lim.u_min_V)) return error("amplitude", "the limits group is not configured: set it first");
        if (p.feedforward == FeedforwardKind::kNone && p.feedback == FeedbackKind::kNone) {
            if (!(lo >= lim.u_min_V && hi <= lim.u_max_V))
                return error("amplitude", "open loop: offset and offset +- amplitude must lie in the limits' [u_min_V, u_max_V]");
        } else if (!(hi - lo <= lim.u_max_V - lim.u_min_V)) {
            return error("amplitude", "closed loop: the span of d must be <= the limits' u_max_V - u_min_V");
        }
        return ok_status();
    }

    // Takes effect at the next tick; d is zero from then on.
    void stop_excitation() { exc_stop_request_.store(true, std::memory_order_release); }
    bool excitation_running() const { return excitation_running_.load(std::memory_order_acquire); }
    // Ticks the excitation ran, and how many of them the limiter clamped to
    // the configured range or slew-limited (valid once it has finished).
    uint32_t excitation_ticks() const { return exc_ticks_; }
    uint32_t excitation_clipped_samples() const { return exc_clipped_; }
    // d of the last tick that ran the excitation.
    T excitation_sample() const { return exc_d_; }
    // Ticks of the running (or last) excitation's lead-in (lead_in.hpp); 0: none.
    uint32_t excitation_lead_in_ticks() const { return lead_in_.ticks(); }

    // One tick: measured displacement in, command out. Bounded time, no
    // allocation, never fails. A tick is three phases, which a board may run
    // apart within its interrupt (firmware/app/control_loop.cpp):
    //   begin_tick()  main-loop requests, bank swap, r, u_ff and the RC's
    //                 correction (from past errors only): nothing here
    //                 depends on the reading, so a board computes it while the
    //                 ADC converts;
    //   output(y)     e, RC's store of e, feedback, limits: the
    //                 ADC-read-to-DAC-write span;
    //   end_tick()    recorder and counters, after the DAC write.
    // tick(y) runs the three in order; split or not, the arithmetic and its
    // order are the same, so host and boards agree bit for bit.
    T tick(T y) {
        // The signals in a local, stored to last_ once: kept in registers,
        // faster on the host than working in last_ (simulator ~190x -> ~205x
        // real time, bench_sim).
        TickSignals<T> s;
        begin_phase(s);
        output_phase(s, y);
        last_ = s;
        end_tick();
        return s.u;
    }

    // The phases apart, for a board's interrupt: the signals live in last_
    // between them (nothing outside the tick reads last_ while a tick is in
    // progress).
    void begin_tick() { begin_phase(last_); }
    T output(T y) {
        output_phase(last_, y);
        return last_.u;
    }
    void end_tick() {
        // The recorder reads the signals it records from last_ directly
        // (TickSignals is in SignalId order, one sample apart: signal i is
        // i samples past r) instead of from a copy of every signal.
        recorder_.push_from(tick_count_, [this](uint8_t i) {
            T v;
            __builtin_memcpy(&v, reinterpret_cast<const unsigned char*>(&last_) + i * sizeof(T), sizeof(T));
            return v;
        });
        ++tick_count_;
    }

    const TickSignals<T>& last() const { return last_; }
    // For a pipeline that joins a stage already running, before its first
    // tick (the host simulator carrying a stage on from an earlier run): the
    // reading the stage gives now. A board's pipeline, ticking all along,
    // holds its latest reading in last_.y, where a wave's approach starts
    // from (approach_sample); a new one would start it from 0 instead. A
    // loop armed before this first tick plans its arming again, from this
    // reading (arm()).
    void join_at_reading(T y) {
        last_.y = y;
        if (armed() && !was_armed_) plan_arming();
    }
    uint32_t tick_count() const { return tick_count_; }
    uint32_t swaps() const { return swaps_; }
    const PipelineParams& params() const { return params_[active_]; }
    const PipelineSetup& setup() const { return setup_; }
    OutputLimiter<T>& limiter() { return limiter_; }
    const OutputLimiter<T>& limiter() const { return limiter_; }
    RecorderType& recorder() { return recorder_; }
    Trajectory& trajectory() { return trajectory_; }

private:
    // TickSignals' members in SignalId order (the recorder's signal
    // indices), one sample apart: end_tick reads signal i at i samples.
    static_assert(std::is_standard_layout_v<TickSignals<T>> && sizeof(TickSignals<T>) == kSignalCount * sizeof(T));
    static_assert(offsetof(TickSignals<T>, r) == signal_index(SignalId::kR) * sizeof(T) &&
                  offsetof(TickSignals<T>, y) == signal_index(SignalId::kY) * sizeof(T) &&
                  offsetof(TickSignals<T>, e) == signal_index(SignalId::kE) * sizeof(T) &&
                  offsetof(TickSignals<T>, u) == signal_index(SignalId::kU) * sizeof(T) &&
                  offsetof(TickSignals<T>, u_ff) == signal_index(SignalId::kUff) * sizeof(T) &&
                  offsetof(TickSignals<T>, u_fb) == signal_index(SignalId::kUfb) * sizeof(T) &&
                  offsetof(TickSignals<T>, u_rc) == signal_index(SignalId::kUrc) * sizeof(T) &&
                  offsetof(TickSignals<T>, d) == signal_index(SignalId::kD) * sizeof(T));

    // The phases, inlined into tick() and into the board's phase calls: as
    // separate functions tick()'s local signals would live on the stack
    // (host: ~3 ns per tick slower, bench_pipeline).
    [[gnu::always_inline]] void begin_phase(TickSignals<T>& s) {
        // The three requests from the main loop, read relaxed and ordered by
        // one acquire fence (one barrier per tick instead of three on
        // Cortex-M): whatever the main loop wrote before setting any of them
        // (the staged bank, the generator's configuration) is visible below.
        const bool pending = swap_pending_.load(std::memory_order_relaxed);
        const bool wave = wave_running_.load(std::memory_order_relaxed);
        const bool armed = armed_.load(std::memory_order_relaxed);
        const bool excite = excitation_running_.load(std::memory_order_relaxed);
        std::atomic_thread_fence(std::memory_order_acquire);
        if (pending && (!was_armed_ || !rc_changes_ || bank().rc.at_period_boundary())) swap_banks();

        if (wave) {
            if (approach_.active()) [[unlikely]] s.r = approach_sample(armed);
            else s.r = trajectory_.step();
            // Load before exchanging: the read-modify-write (and its barriers)
            // only happens on the tick a stop was actually requested.
            if (trajectory_.done() ||
                (stop_request_.load(std::memory_order_relaxed) &&
                 stop_request_.exchange(false, std::memory_order_acq_rel))) {
                setpoint_ = s.r;
                wave_running_.store(false, std::memory_order_release);
            }
        } else {
            stop_request_.store(false, std::memory_order_relaxed);
            s.r = setpoint_;
        }
        // One reference for the whole phase: re-indexing banks_ by active_
        // after every byte-sized store (which may alias active_) costs a
        // reload and a multiply each time.
        Bank& b = bank();
        if (b.pf_count > 0) [[unlikely]] s.r = b.prefilter.apply(s.r);
        s.d = sample_zero<T>();
        if (excite) [[unlikely]] excitation_phase(s);
        if (armed && !was_armed_) {
            b.reset();
            if (arm_preset_) b.pi.start_ascended_to(arm_turn_);
        }
        was_armed_ = armed;
        // The cascade's states as they are before this tick's sample, for its
        // anti-windup: taken here, before the reading, so the copy stays out
        // of the ADC-read-to-DAC-write span.
        if (armed && b.sos_anti_windup_on) b.sos_anti_windup.before(b.sos);
        s.u_ff = armed ? b.feedforward(s.r) : sample_zero<T>();
        // The RC's correction depends only on its delay line's past
        // (repetitive.hpp): computed here, out of the ADC-read-to-DAC-write
        // span; output_phase stores this tick's error.
        s.u_rc = armed && b.rc_enabled ? b.rc.prepare() : sample_zero<T>();
    }

    [[gnu::always_inline]] void output_phase(TickSignals<T>& s, T y) {
        s.y = y;
        s.e = s.r - s.y;
        if (was_armed_) {
            Bank& b = bank();
            T e_fb = s.e;
            if (b.rc_enabled) {
                b.rc.push(s.e);
                e_fb = s.e + s.u_rc;
            }
            s.u_fb = b.feedback_apply(e_fb);
            // Series placement: the compensator needs u_fb, so it runs here
            // (begin_phase left u_ff at zero). The other kinds pay one
            // well-predicted branch; their arithmetic is unchanged.
            T command;
            if (b.ff_kind == FeedforwardKind::kPiSeries) [[unlikely]] {
                s.u_ff = b.pi.apply(s.r + s.u_fb);
                command = s.u_ff;
            } else {
                command = s.u_ff + s.u_fb;
            }
            if (exc_active_) [[unlikely]] {
                s.u = excited_output(command, s.d);
            } else {
                s.u = limiter_.apply(command);
            }
            if (b.sos_anti_windup_on) b.sos_anti_windup.after(b.sos, e_fb, limiter_.clamp_direction());
        } else {
            s.u_fb = sample_zero<T>();
            s.u = limiter_.apply(sample_zero<T>());
            exc_active_ = false;  // disarmed: the excitation is not applied
        }
    }

    // r while the approach is pending or moving: its first tick takes the
    // start (the setpoint if the loop stays armed, else the last reading,
    // which tick() and the board's phases both hold in last_.y here); when
    // there is nothing to approach the wave starts on this tick.
    [[gnu::noinline]] T approach_sample(bool armed) {
        if (approach_.pending()) {
            const bool from_setpoint = armed && was_armed_;
            const T from = from_setpoint ? setpoint_ : last_.y;
            if (!from_setpoint) settle_prefilter(from);
            (void)approach_.begin(from);
        }
        if (approach_.moving()) return approach_.step();
        return trajectory_.step();
    }
    // The parameter set the next tick runs: the staged one while a swap is
    // pending. The tick may swap while this reads; the pending flag read on
    // both sides of the bank index tells (only the main loop stages).
    const PipelineParams& params_at_next_tick() const {
        for (;;) {
            const bool pending_before = swap_pending_.load(std::memory_order_acquire);
            const unsigned active = *static_cast<const volatile unsigned*>(&active_);
            const bool pending_after = swap_pending_.load(std::memory_order_acquire);
            if (pending_before == pending_after) return params_[pending_after ? active ^ 1u : active];
        }
    }

    // A start from the stage's reading: the pre-filter, which ran on the
    // held setpoint, is put at its steady state for the reading, so its
    // output starts where the stage is instead of stepping from the
    // setpoint to it (a step that would ring the stage's modes). From the
    // setpoint of an armed loop it is left alone: its input goes on without
    // a step, and its output is what the loop tracks.
    void settle_prefilter(T from) {
        Bank& b = bank();
        if (b.pf_count > 0) b.prefilter.settle(from);
    }

    // The excitation's part of begin_phase: d of this tick, added to r here
    // or to the command in output_phase (which clears exc_active_ again). The
    // tick that ends it (last period, or a stop request) still applies its d.
    void excitation_phase(TickSignals<T>& s) {
        exc_d_ = excitation_.step();
        if (!exc_to_command_) {
            // At the reference d starts from zero: r from where it was.
            if (lead_in_.pending()) [[unlikely]] lead_in_.begin(sample_zero<T>(), exc_d_);
            if (lead_in_.active()) [[unlikely]] exc_d_ = lead_in_.blend(exc_d_);
            s.r = s.r + exc_d_;
        }
        s.d = exc_d_;
        exc_active_ = true;
        if (excitation_.done() || (exc_stop_request_.load(std::memory_order_relaxed) &&
                                   exc_stop_request_.exchange(false, std::memory_order_acq_rel)))
            excitation_running_.store(false, std::memory_order_release);
    }
    // The limiter with the excitation on: d added at the command (from the
    // value that leaves the command where it was: the lead-in), and the
    // samples the limiter changed counted.
    T excited_output(T command, T& d) {
        if (exc_to_command_) {
            if (lead_in_.pending()) [[unlikely]] lead_in_.begin(limiter_.output() - command, exc_d_);
            if (lead_in_.active()) [[unlikely]] d = exc_d_ = lead_in_.blend(exc_d_);
            command = command + exc_d_;
        }
        const uint32_t before = limiter_.clamped_samples() + limiter_.slew_limited_samples();
        const T u = limiter_.apply(command);
        if (limiter_.clamped_samples() + limiter_.slew_limited_samples() != before) ++exc_clipped_;
        ++exc_ticks_;
        exc_active_ = false;  // begin_phase sets it again while the excitation runs
        return u;
    }

    // One complete, configured controller. Two of them make the double buffer.
    struct Bank {
        // The flags the tick tests every time and the blocks it runs every
        // time first, at small offsets from the bank's address.
        FeedforwardKind ff_kind = FeedforwardKind::kNone;
        FeedbackKind fb_kind = FeedbackKind::kNone;
        bool sos_anti_windup_on = false;  // kSos feedback with a DC gain (anti_windup.hpp)
        bool rc_enabled = false;
        int pf_count = 0;
        BiquadCascade<T, kMaxControllerSections> sos{};
        PiOperator<T> pi{};
        CascadeAntiWindup<T, kMaxControllerSections> sos_anti_windup{};
        Pid<T> pid{};
        DahlFeedforward dahl{};
        BiquadCascade<T, kMaxPrefilterSections> prefilter{};  // not reset at arming: it runs disarmed too
        SignalScale position{}, voltage{};
        // Last: its delay line is long (RcCapacity samples), and the blocks
        // above stay within a load's immediate offset of the bank's address.
        RepetitiveController<T, RcCapacity> rc{};

        T feedforward(T r) {
            switch (ff_kind) {
                case FeedforwardKind::kPiInverse:
                case FeedforwardKind::kPiCompensator:
                    return pi.apply(r);
                case FeedforwardKind::kDahl:
                    // The Dahl model runs in float in both pipelines: its
                    // state sits near an equilibrium with transients many
                    // decades smaller (dahl.hpp, DahlDeviation), which a
                    // fixed-point format would not resolve. In Q31 (software
                    // float on the M3) r and u_ff are converted around it; it
                    // depends on r only, so it runs before the reading.
                    if constexpr (kFloat) return dahl.step(r);
                    else return voltage.template to_sample<T>(dahl.step(position.to_physical(r)));
                case FeedforwardKind::kPiSeries:  // runs in output_phase, after the feedback
                case FeedforwardKind::kNone:
                    break;
            }
            return sample_zero<T>();
        }
        T feedback_apply(T e) {
            switch (fb_kind) {
                case FeedbackKind::kSos: return sos.apply(e);
                case FeedbackKind::kPid: return pid.apply(e);
                case FeedbackKind::kNone: break;
            }
            return sample_zero<T>();
        }
        void reset() {
            pi.reset();
            if (ff_kind == FeedforwardKind::kDahl) dahl.reset(0.0f);
            sos.reset();
            pid.reset();
            rc.reset();
        }
    };

    Status configure_bank(const PipelineParams& p, Bank& b) const {
        b.position = setup_.position;
        b.voltage = setup_.voltage;
        b.ff_kind = p.feedforward;
        b.sos_anti_windup_on = false;
        switch (p.feedforward) {
            case FeedforwardKind::kNone:
                break;
            case FeedforwardKind::kPiInverse: {
                PiModel inverse{};
                if (const Status s = invert_pi(p.pi, inverse); !s.ok()) return in_group("pi", s);
                if (const Status s = b.pi.configure(inverse, setup_.position, setup_.voltage); !s.ok())
                    return in_group("pi", s);
                break;
            }
            case FeedforwardKind::kPiCompensator:
            case FeedforwardKind::kPiSeries:
                if (const Status s = b.pi.configure(p.pi, setup_.position, setup_.voltage); !s.ok())
                    return in_group("pi", s);
                break;
            case FeedforwardKind::kDahl:
                if (const Status s = b.dahl.configure(p.dahl); !s.ok()) return in_group("dahl", s);
                break;
            default:
                return error("feedforward", "must be none, pi_inverse, pi_compensator, dahl or pi_series");
        }
        // Series placement: the feedback corrects the displacement command,
        // so its output is in µm (in Q31: scaled by the position full scale).
        const bool series = p.feedforward == FeedforwardKind::kPiSeries;
        if (series && p.feedback == FeedbackKind::kNone)
            return error("feedforward", "pi_series puts the compensator after the feedback: set feedback (sos or pid)");
        const SignalScale fb_out = series ? setup_.position : setup_.voltage;
        b.fb_kind = p.feedback;
        switch (p.feedback) {
            case FeedbackKind::kNone:
                break;
            case FeedbackKind::kSos:
                if (p.sos_count < 1 || p.sos_count > kMaxControllerSections)
                    return error("sos_count", "must be in [1, 4]");
                if (const Status s = b.sos.configure(p.sos.data(), p.sos_count, setup_.position, fb_out);
                    !s.ok())
                    return in_group("sos", s);
                b.sos_anti_windup.configure(p.sos.data(), p.sos_count);
                b.sos_anti_windup_on = b.sos_anti_windup.dc_sign() != 0;
                break;
            case FeedbackKind::kPid:
                if (const Status s = b.pid.configure(p.pid, setup_.rate_Hz, setup_.position, fb_out);
                    !s.ok())
                    return in_group("pid", s);
                break;
            default:
                return error("feedback", "must be none, sos or pid");
        }
        if (p.prefilter_count < 0 || p.prefilter_count > kMaxPrefilterSections)
            return error("prefilter_count", "must be in [0, 2]");
        b.pf_count = p.prefilter_count;
        if (p.prefilter_count > 0) {
            if (const Status s = b.prefilter.configure(p.prefilter.data(), p.prefilter_count, setup_.position,
                                                       setup_.position);
                !s.ok()) {
                // Named as the feedforward group holds it ("prefilter[1].a2"),
                // the way its field checks and a scenario's controller name it.
                const Status named = detail::renamed_sos_error<kMaxPrefilterSections, kPrefilterName>(s);
                return named.field == s.field ? in_group("prefilter", s) : named;
            }
        }
        b.rc_enabled = p.rc_enabled;
        if (p.rc_enabled) {
            if (p.feedback == FeedbackKind::kNone)
                return error("rc_enabled", "repetitive control plugs into a feedback loop: set feedback");
            if (const Status s = b.rc.configure(p.rc); !s.ok()) return in_group("rc", s);
        }
        b.reset();
        return ok_status();
    }

    // The tick's bank by pointer: one load, where indexing by active_ costs
    // a load and a multiply-add each time the compiler rematerialises it.
    Bank& bank() { return *bank_; }

    void swap_banks() {
        const Bank& old = banks_[active_];
        const PipelineParams& po = params_[active_];
        Bank& next = banks_[active_ ^ 1u];
        const PipelineParams& pn = params_[active_ ^ 1u];
        // Unchanged blocks continue with their state (configured identically,
        // so copying the whole block is exact); changed ones start from rest.
        next.reset();
        if (pn.feedforward == po.feedforward && pn.pi == po.pi && pn.dahl == po.dahl) {
            next.pi = old.pi;
            next.dahl = old.dahl;
        }
        // The feedback's output unit follows the placement (V, or µm in
        // series): a change of placement restarts it.
        const bool same_placement =
            (pn.feedforward == FeedforwardKind::kPiSeries) == (po.feedforward == FeedforwardKind::kPiSeries);
        if (same_placement && pn.feedback == po.feedback && pn.sos_count == po.sos_count && pn.sos == po.sos &&
            pn.pid == po.pid) {
            next.sos = old.sos;
            next.pid = old.pid;
        }
        if (!rc_changes_) next.rc = old.rc;
        if (pn.prefilter_count == po.prefilter_count && pn.prefilter == po.prefilter)
            next.prefilter = old.prefilter;
        else
            next.prefilter.reset();
        active_ ^= 1u;
        bank_ = &banks_[active_];
        // Prepared in stage(); the limiter keeps its last output and slews
        // into the new range.
        limiter_.apply_setting(limits_next_);
        ++swaps_;
        swap_pending_.store(false, std::memory_order_release);
    }

    // What the tick reads every time first, within a load's immediate
    // offset of the pipeline's address (VLDR/VSTR reach 1020 bytes); the
    // banks, the recorder's frames and the excitation's table after them.
    std::atomic<bool> swap_pending_{false};
    std::atomic<bool> armed_{false};
    std::atomic<bool> wave_running_{false};
    std::atomic<bool> stop_request_{false};
    std::atomic<bool> excitation_running_{false};
    std::atomic<bool> exc_stop_request_{false};
    bool was_armed_ = false;
    bool rc_changes_ = false;      // the pending set changes the RC (written before swap_pending_)
    bool exc_to_command_ = false;  // kCommand (written before excitation_running_)
    bool exc_prepared_ = false;    // configured by prepare_excitation, not yet run (main loop only)
    bool exc_active_ = false;      // this tick adds d (set in begin_phase, read in output_phase)
    Bank* bank_ = &banks_[0];      // banks_[active_]
    TickSignals<T> last_{};
    T setpoint_{};
    T exc_d_{};
    T arm_turn_{};             // the PI compensator's start state at the next arming
    bool arm_preset_ = false;  // (both written by the plan, before armed_ is set)
    uint32_t tick_count_ = 0;
    uint32_t swaps_ = 0;
    unsigned active_ = 0;
    OutputLimiter<T> limiter_;
    Trajectory trajectory_;
    Approach<T> approach_;  // read by the tick only while a wave runs
    PipelineSetup setup_;
    typename OutputLimiter<T>::Setting limits_next_{};  // for the pending swap
    RecorderType recorder_{};
    Excitation excitation_{};
    LeadIn<T> lead_in_{};  // the excitation's first samples (main loop prepares, tick runs)
    uint32_t exc_clipped_ = 0, exc_ticks_ = 0;
    uint32_t rejected_setpoints_ = 0;
    PipelineParams params_[2]{};
    // Last: the tick reaches its bank through bank_, and each bank carries
    // the RC's delay line (RcCapacity samples), which would otherwise push
    // the recorder's indices beyond a load's immediate offset.
    Bank banks_[2]{};
};

// The PI compensator's start state for the next arming (main loop): for the
// first reference x and the limiter's output. Zero states when no PI
// compensator runs or theirs already give that output within 1e-4 of the
// command's full scale.
template <class T, int RcCapacity, std::size_t RecChannels, std::size_t RecCapacity, std::size_t ExcCapacity>
void Pipeline<T, RcCapacity, RecChannels, RecCapacity, ExcCapacity>::plan_arming_from(T x) {
    arm_preset_ = false;
    const PipelineParams& p = params_at_next_tick();
    if (p.feedforward != FeedforwardKind::kPiInverse && p.feedforward != FeedforwardKind::kPiCompensator &&
        p.feedforward != FeedforwardKind::kPiSeries)
        return;
    PiModel m = p.pi;
    if (p.feedforward == FeedforwardKind::kPiInverse && !invert_pi(p.pi, m).ok()) return;
    const PiStartState start =
        pi_start_for_output(m, setup_.position.to_physical(x), setup_.voltage.to_physical(limiter_.output()),
                            1e-4 * static_cast<double>(setup_.voltage.full_scale));
    if (!start.preset) return;
    arm_turn_ = setup_.position.template to_sample<T>(static_cast<float>(start.turn));
    arm_preset_ = true;
}

}  // namespace piezoloop
