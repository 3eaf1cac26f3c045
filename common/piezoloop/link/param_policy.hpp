// What the device does with a parameter group of one axis it is sent
// (SetParams), and which set it reports (GetParams). Each axis has its own
// policy; the board's groups (recorder, link, matrices) are
// link/board_policy.hpp's.
//
// A group goes through, in this order:
//   1. equal to the running group and nothing waiting: acknowledged, nothing staged;
//   2. busy while a previous set waits for its swap (ErrorCode::kBusy);
//   3. limit-critical fields (declared in params/groups.hpp) change only
//      while disarmed (ErrorCode::kArmed, naming the first changed field);
//   4. the field check against the declaration (params/field_check.hpp);
//   5. the block's own checks, then Pipeline::stage(): a new PipelineParams
//      is the running one plus this group, so a rejected set leaves the
//      running one untouched and an accepted one is swapped in at the next
//      tick boundary.
// Limit-critical: limits (every field, they bound the output), the PID's
// u_min / u_max, and feedforward kind, feedback kind, sos_count, rc enabled
// and prefilter_count (they replace a block, which would restart from rest
// inside a running loop; the pipeline refuses new pre-filter coefficients
// while armed too). Everything else is swapped in while armed, with the
// limiter (not banked) slewing the output across the change.
// The trajectory is validated by a scratch generator and stored (StartWave
// runs it).
//
// An axis's part of a whole stored set (Load, and the load at boot:
// check_all, then set_all) goes through steps 2, 4 and 5 for every group it
// holds; the device checks every axis and the board's groups before it
// applies any, so a set with one bad group changes nothing. The caller
// refuses it while armed (it replaces limit-critical groups).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "piezoloop/link/messages.hpp"
#include "piezoloop/params/field_check.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/storage/stored_params.hpp"

namespace piezoloop::link {

template <class Pipeline>
class ParamPolicy {
public:
    using T = typename Pipeline::SampleType;

    explicit ParamPolicy(Pipeline& pipeline) : pipeline_(pipeline) {}

    // Applies a group; on error, code() says which ErrorCode the reply carries.
    template <class G>
    Status set(const G& v) {
        const Status s = as_user_path(apply(v));
        if (!s.ok() && s.group == nullptr) return in_group(group_name(G::kGroup), s);
        return s;
    }
    ErrorCode code() const { return code_; }
    // For a check of the caller's own that code() reports.
    void note_code(ErrorCode c) { code_ = c; }

    // Applies the axis's part of a stored set that check_all() passed, or
    // nothing; on error code() as for set().
    Status set_all(const storage::StoredAxis& v) {
        if (pipeline_.swap_pending())
            return fail(ErrorCode::kBusy, error("params", "previous parameter set not yet swapped in; retry after one tick"));
        PipelineParams p = pipeline_.params();
        params::set_group(p, v.limits);
        params::set_group(p, v.feedforward);
        params::set_group(p, v.feedback);
        params::set_group(p, v.rc);
        if (const Status s = as_user_path(pipeline_.stage(p)); !s.ok())
            return fail(ErrorCode::kInvalidParam, s.group == nullptr ? in_group("params", s) : s);
        staged_ = p;
        // Checked by check_all: cannot fail now.
        if (v.has_trajectory) (void)apply(v.trajectory);
        return ok_status();
    }

    // Steps 4 and 5 for every group of a whole set, nothing applied: what
    // set_all() checks before it applies (Load, the load at boot) and what
    // Save checks before it stores, so a saved set is one the board loads.
    // (The pipeline's check of the groups together, in stage(), passed
    // when the running set was staged; a set never staged holds the default
    // limits, which fail here.) On error code() as for set().
    Status check_all(const storage::StoredAxis& v) {
        if (const Status s = check_group(v.limits); !s.ok()) return s;
        if (const Status s = check_group(v.feedforward); !s.ok()) return s;
        if (const Status s = check_group(v.feedback); !s.ok()) return s;
        if (const Status s = check_group(v.rc); !s.ok()) return s;
        if (v.has_trajectory) {
            if (const Status s = check_group(v.trajectory); !s.ok()) return s;
        }
        return ok_status();
    }

    // Everything set_all() applies, as GetParams reports it.
    void all(storage::StoredAxis& s) const {
        s = storage::StoredAxis{};
        s.limits = get<LimitsParams>();
        s.feedforward = get<FeedforwardParams>();
        s.feedback = get<FeedbackParams>();
        s.rc = get<RepetitiveParams>();
        s.has_trajectory = wave_set_;
        s.trajectory = wave_;
    }

    // The newest accepted set (GetParams): the staged one until it is swapped in.
    const PipelineParams& params() const { return pipeline_.swap_pending() ? staged_ : pipeline_.params(); }
    bool wave_set() const { return wave_set_; }
    const TrajectoryParams& wave() const { return wave_; }

    // Each group as GetParams returns it.
    template <class G>
    G get() const {
        if constexpr (std::is_same_v<G, TrajectoryParams>) return wave_;
        else if constexpr (std::is_same_v<G, FeedforwardParams>) return params::feedforward_of(params());
        else if constexpr (std::is_same_v<G, FeedbackParams>) return params::feedback_of(params());
        else if constexpr (std::is_same_v<G, RepetitiveParams>) return params::rc_of(params());
        else return params::limits_of(params());
    }

    TrajectoryConfig wave_config() const { return trajectory_config(wave_); }

private:
    Status fail(ErrorCode code, Status s) {
        code_ = code;
        return s;
    }

    // Steps 2 and 3.
    template <class G>
    Status busy_or_armed(const G& from, const G& to) {
        if (pipeline_.swap_pending())
            return fail(ErrorCode::kBusy, error("params", "previous parameter set not yet swapped in; retry after one tick"));
        if (pipeline_.armed()) {
            if (const char* field = params::first_critical_change(from, to, critical_field_))
                return fail(ErrorCode::kArmed, error(field, "limit-critical: changes only while disarmed"));
        }
        return ok_status();
    }

    // Steps 4 and 5 of one group of a whole set, nothing applied; errors
    // named with the group as set() names them.
    template <class G>
    Status check_group(const G& v) {
        Status s = check_only(v);
        if (!s.ok() && s.group == nullptr) s = in_group(group_name(G::kGroup), s);
        return s;
    }
    template <class G>
    Status check_only(const G& v) {
        if (const Status s = check_.check(v); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        if (const Status s = block_checks(v); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        return ok_status();
    }
    Status check_only(const TrajectoryParams& v) {
        if (const Status s = check_.check(v); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        TrajectoryGenerator<T, kMaxWaveTable> scratch(pipeline_.setup().position);
        if (const Status s = scratch.configure(trajectory_config(v)); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        return ok_status();
    }
    // Steps 2 to 5 for a group of the pipeline's parameter set.
    template <class G>
    Status stage_group(const G& current, const G& v) {
        if (const Status s = busy_or_armed(current, v); !s.ok()) return s;
        if (const Status s = check_.check(v); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        if (const Status s = block_checks(v); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        PipelineParams p = pipeline_.params();
        params::set_group(p, v);
        const Status s = pipeline_.stage(p);
        if (!s.ok()) return fail(ErrorCode::kInvalidParam, s);
        staged_ = p;
        return s;
    }

    // A block's error "thresholds" reported as the group's field "pi.thresholds".
    Status nested(const char* prefix, Status s) {
        if (s.ok()) return s;
        nested_field_.clear();
        nested_field_.append(prefix);
        nested_field_.append(".");
        nested_field_.append(s.field);
        s.field = nested_field_.c_str();
        return s;
    }

    // The core names a block's error by the block ("pid", field "kp"); the
    // user sets the block inside a link group, so the reply names the path
    // the user writes: group "feedback", field "pid.kp". The feedback's
    // sections are the group's own field ("sections[1].a2").
    Status as_user_path(Status s) {
        struct Block {
            const char* block;
            const char* group;
            const char* prefix;  // null: the block's fields are the group's
        };
        static constexpr Block kBlocks[] = {
            {"pi", "feedforward", "pi"},        {"dahl", "feedforward", "dahl"},
            {"prefilter", "feedforward", "prefilter"}, {"sos", "feedback", nullptr},
            {"pid", "feedback", "pid"},
        };
        if (s.ok() || s.group == nullptr) return s;
        for (const Block& b : kBlocks) {
            if (!piezoloop::detail::same_text(s.group, b.block)) continue;
            if (b.prefix != nullptr) s = nested(b.prefix, s);
            s.group = b.group;
            return s;
        }
        return s;
    }

    Status block_checks(const FeedforwardParams& v) { return nested("pi", piezoloop::validate(v.pi)); }
    Status block_checks(const FeedbackParams&) { return ok_status(); }
    Status block_checks(const LimitsParams&) { return ok_status(); }
    Status block_checks(const RepetitiveParams& v) {
        if (!v.enabled) return ok_status();
        // Checked here even though the pipeline checks RC only with a feedback,
        // so the error names the RC field. (No scratch RepetitiveController:
        // its delay line would put RcCapacity samples on the main loop's stack.)
        if (const Status s = Pipeline::RepetitiveType::validate(v.rc); !s.ok()) return s;
        BiquadCascade<T, 1> q;
        const SignalScale unit{1.0f};
        if (const Status s = q.configure(&v.rc.q, 1, unit, unit); !s.ok()) return error("q", s.message);
        return ok_status();
    }

    Status apply(const FeedforwardParams& v) {
        const FeedforwardParams cur = params::feedforward_of(pipeline_.params());
        if (v == cur && !pipeline_.swap_pending()) return ok_status();
        return stage_group(cur, v);
    }
    Status apply(const FeedbackParams& v) {
        const FeedbackParams cur = params::feedback_of(pipeline_.params());
        if (v == cur && !pipeline_.swap_pending()) return ok_status();
        return stage_group(cur, v);
    }
    Status apply(const RepetitiveParams& v) {
        const RepetitiveParams cur = params::rc_of(pipeline_.params());
        if (v == cur && !pipeline_.swap_pending()) return ok_status();
        return stage_group(cur, v);
    }
    Status apply(const LimitsParams& v) {
        const LimitsParams cur = params::limits_of(pipeline_.params());
        // Limits also configure the limiter, so an unchanged set is staged
        // anyway while nothing has configured it yet.
        if (v == cur && pipeline_.limiter().configured() && !pipeline_.swap_pending()) return ok_status();
        return stage_group(cur, v);
    }

    Status apply(const TrajectoryParams& v) {
        if (const Status s = check_.check(v); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        // Validated by a scratch generator at the loop rate; stored, and run by StartWave.
        TrajectoryGenerator<T, kMaxWaveTable> scratch(pipeline_.setup().position);
        if (const Status s = scratch.configure(trajectory_config(v)); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        wave_ = v;
        wave_set_ = true;
        return ok_status();
    }

    TrajectoryConfig trajectory_config(const TrajectoryParams& v) const {
        return params::trajectory_config(v, pipeline_.setup().rate_Hz);
    }

    Pipeline& pipeline_;
    ErrorCode code_ = ErrorCode::kInvalidParam;
    PipelineParams staged_{};
    TrajectoryParams wave_{};
    bool wave_set_ = false;
    params::FieldCheck check_{};
    params::TextBuffer<32> critical_field_{};
    params::TextBuffer<32> nested_field_{};
};

}  // namespace piezoloop::link
