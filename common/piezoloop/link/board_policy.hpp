// What the device does with the groups of the whole board (SetParams /
// GetParams with axis 0): the recorder, the link group and the multi-axis
// matrices. The groups of one axis are link/param_policy.hpp's.
//
// Recorder: its channels are (axis, signal) pairs. The board's recorder
// (MultiAxisPipeline::recorder(), or a single-axis device's pipeline
// recorder) indexes its signals as axis * kSignalCount + signal, so on one
// axis a channel's index is its signal, as before axes; the board's sync word
// (channel "sync", axis 0) is kMaxAxes * kSignalCount on every board of axes.
// It is configured at once, inside the tick mask.
//
// Matrices (input_matrix, output_matrix): 3 x 3 layouts whose top-left
// axis_count x axis_count block is the board's matrix (the rest must be the
// identity's), validated by the core (axes/axis_matrix.hpp) and refused while
// any axis is armed; a refused matrix changes nothing. A device over a single
// Pipeline has no matrix stage: it reports the identity and accepts only it.
//
// Errors: code() says which ErrorCode the reply carries, as ParamPolicy's.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "piezoloop/axes/axis_matrix.hpp"
#include "piezoloop/link/messages.hpp"
#include "piezoloop/params/field_check.hpp"
#include "piezoloop/pipeline.hpp"
#include "piezoloop/storage/stored_params.hpp"

namespace piezoloop::link {

// What an axis index must be on a board of N axes.
template <int N>
constexpr const char* axis_range_message() {
    if constexpr (N == 1) return "must be 0: this board has one axis (hello axis_count)";
    else if constexpr (N == 2) return "must be 0..1: this board has 2 axes (hello axis_count)";
    else return "must be 0..2: this board has 3 axes (hello axis_count)";
}

// Multi: the MultiAxisPipeline type, or void for a device over one Pipeline.
template <class T, int N, class RecorderType, class Multi>
class BoardPolicy {
    static constexpr bool kMatrices = !std::is_void_v<Multi>;
    using MultiPtr = std::conditional_t<kMatrices, Multi*, void*>;

public:
    static constexpr std::size_t kRecChannels = RecorderType::kChannels;

    // setups: each axis's (scales, rate); every axis at axes[0]'s rate.
    BoardPolicy(RecorderType& recorder, const std::array<const PipelineSetup*, N>& setups, MultiPtr multi,
                void (*mask_tick)(bool))
        : recorder_(recorder), setups_(setups), multi_(multi), mask_tick_(mask_tick) {}

    ErrorCode code() const { return code_; }

    template <class G>
    Status set(const G& v) {
        Status s = apply(v);
        if (!s.ok() && s.group == nullptr) s = in_group(group_name(G::kGroup), s);
        return s;
    }

    template <class G>
    G get() const {
        if constexpr (std::is_same_v<G, RecorderParams>) return recorder_params();
        else if constexpr (std::is_same_v<G, LinkParams>) return link_;
        else if constexpr (std::is_same_v<G, InputMatrixParams>) return input_params();
        else return output_params();
    }

    const LinkParams& link() const { return link_; }
    // The client timeout in ticks (0: never).
    uint32_t client_timeout_ticks() const { return client_timeout_ticks_; }

    // The board's part of a stored set: checked, nothing applied.
    Status check_all(const storage::StoredParams& v) {
        if (v.has_recorder) {
            if (const Status s = named(check(v.recorder), ParamGroup::kRecorder); !s.ok()) return s;
        }
        if (const Status s = named(check(v.link), ParamGroup::kLink); !s.ok()) return s;
        if (const Status s = named(check(v.input_matrix), ParamGroup::kInputMatrix); !s.ok()) return s;
        if (const Status s = named(check(v.output_matrix), ParamGroup::kOutputMatrix); !s.ok()) return s;
        return ok_status();
    }
    // Applies what check_all() passed (every axis disarmed). The matrices
    // can still be refused while a previous one waits to be taken over.
    Status set_all(const storage::StoredParams& v) {
        if (const Status s = set(v.input_matrix); !s.ok()) return s;
        if (const Status s = set(v.output_matrix); !s.ok()) return s;
        if (v.has_recorder) (void)set(v.recorder);  // checked: cannot fail
        (void)set(v.link);
        return ok_status();
    }
    void all(storage::StoredParams& s) const {
        s.has_recorder = recorder_.configured();
        s.recorder = recorder_params();
        s.link = link_;
        s.input_matrix = input_params();
        s.output_matrix = output_params();
    }

private:
    Status fail(ErrorCode code, Status s) {
        code_ = code;
        return s;
    }
    Status named(Status s, ParamGroup g) const {
        if (!s.ok() && s.group == nullptr) return in_group(group_name(g), s);
        return s;
    }
    void mask(bool m) const {
        if (mask_tick_ != nullptr) mask_tick_(m);
    }

    // ---- recorder -------------------------------------------------------------

    RecorderParams recorder_params() const {
        const auto& c = recorder_.config();
        // Configured or not, the group is a valid set (an unconfigured
        // recorder holds the defaults: every channel r of axis 0, every
        // tick, single shot of the whole capacity), so a client that changes
        // one field of it sends a set that is checked on what it changed.
        RecorderParams r;
        r.channel_count = static_cast<uint8_t>(kRecChannels);
        for (std::size_t i = 0; i < kRecChannels; ++i) {
            const bool sync = c.channels[i] >= kMaxAxes * kSignalCount;
            r.channels[i] = sync ? params::kSyncChannel : static_cast<uint8_t>(c.channels[i] % kSignalCount);
            r.axes[i] = sync ? 0 : static_cast<uint8_t>(c.channels[i] / kSignalCount);
        }
        r.decimation = c.decimation;
        r.mode = c.mode;
        r.trigger = c.trigger;
        r.trigger_signal = static_cast<uint8_t>(c.trigger_signal % kSignalCount);
        r.trigger_axis = static_cast<uint8_t>(c.trigger_signal / kSignalCount);
        r.trigger_level = c.trigger_level;
        r.pre_trigger = c.pre_trigger;
        r.length = c.length;
        return r;
    }

    typename RecorderType::Config recorder_config(const RecorderParams& v) const {
        typename RecorderType::Config c{};
        for (std::size_t i = 0; i < kRecChannels; ++i)
            c.channels[i] = v.channels[i] == params::kSyncChannel ? static_cast<uint8_t>(kMaxAxes * kSignalCount)
                                                                  : static_cast<uint8_t>(v.axes[i] * kSignalCount + v.channels[i]);
        c.decimation = v.decimation;
        c.mode = v.mode;
        c.trigger = v.trigger;
        c.trigger_signal = static_cast<uint8_t>(v.trigger_axis * kSignalCount + v.trigger_signal);
        c.trigger_level = v.trigger_level;
        // r, y, e are positions; u, u_ff, u_fb, u_rc voltages.
        const PipelineSetup& s = *setups_[v.trigger_axis < N ? v.trigger_axis : 0];
        c.trigger_scale = v.trigger_signal <= signal_index(SignalId::kE) ? s.position : s.voltage;
        c.pre_trigger = v.pre_trigger;
        c.length = v.length;
        return c;
    }

    Status check(const RecorderParams& v) {
        if (v.channel_count != kRecChannels)
            return fail(ErrorCode::kUnsupported,
                        error("channel_count", "must equal the device's recorder channel count (hello)"));
        if (const Status s = check_.check(v); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        for (std::size_t i = 0; i < kRecChannels; ++i) {
            if (v.axes[i] >= N)
                return fail(ErrorCode::kInvalidParam,
                            error("axes", static_cast<int>(i), axis_range_message<N>()));
            if (v.channels[i] == params::kSyncChannel && (!kMatrices || N < 2))
                return fail(ErrorCode::kInvalidParam,
                            error("channels", static_cast<int>(i),
                                  "sync: the scan signal of a board of two or three axes; this board has one axis"));
            if (v.channels[i] == params::kSyncChannel && v.axes[i] != 0)
                return fail(ErrorCode::kInvalidParam,
                            error("axes", static_cast<int>(i), "must be 0 for sync (the board's signal)"));
        }
        if (v.trigger_axis >= N) return fail(ErrorCode::kInvalidParam, error("trigger_axis", axis_range_message<N>()));
        if (const Status s = RecorderType::validate(recorder_config(v)); !s.ok())
            return fail(ErrorCode::kInvalidParam, s);
        return ok_status();
    }
    Status apply(const RecorderParams& v) {
        if (const Status s = check(v); !s.ok()) return s;
        mask(true);
        const Status s = recorder_.configure(recorder_config(v));
        mask(false);
        if (!s.ok()) return fail(ErrorCode::kInvalidParam, s);
        return ok_status();
    }

    // ---- link -----------------------------------------------------------------

    Status check(const LinkParams& v) {
        if (const Status s = check_.check(v); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        return ok_status();
    }
    Status apply(const LinkParams& v) {
        if (const Status s = check(v); !s.ok()) return s;
        link_ = v;
        client_timeout_ticks_ = timeout_ticks(v.client_timeout_s);
        return ok_status();
    }

    // Seconds to ticks, to the nearest tick, and at least one tick for any
    // timeout above 0 (only 0 means never: a timeout shorter than half a
    // tick would otherwise round to 0); at most 2^32 - 1 ticks.
    uint32_t timeout_ticks(float s) const {
        if (!(s > 0.0f)) return 0;
        const double t = static_cast<double>(s) * static_cast<double>(setups_[0]->rate_Hz) + 0.5;
        if (!(t >= 1.0)) return 1;
        return t >= 4294967295.0 ? 0xffffffffu : static_cast<uint32_t>(t);
    }

    // ---- matrices -------------------------------------------------------------

    static constexpr std::size_t kLayoutAxes = params::kMaxGroupAxes;

    InputMatrixParams input_params() const {
        InputMatrixParams p;
        p.axis_count = static_cast<uint8_t>(N);
        if constexpr (kMatrices) {
            const InputMatrix<N>& m = multi_->input_matrix();
            for (int i = 0; i < N; ++i) {
                for (int j = 0; j < N; ++j) p.gain[i * kLayoutAxes + j] = m.gain.m[i][j];
                p.offset_um[i] = m.offset_um[i];
            }
        }
        return p;
    }
    OutputMatrixParams output_params() const {
        OutputMatrixParams p;
        p.axis_count = static_cast<uint8_t>(N);
        if constexpr (kMatrices) {
            const AxisMatrix<N>& m = multi_->output_matrix();
            for (int i = 0; i < N; ++i)
                for (int j = 0; j < N; ++j) p.gain[i * kLayoutAxes + j] = m.m[i][j];
        }
        return p;
    }

    // The layout's form: the board's axis count, the identity outside the
    // board's block. Then the core's validation.
    template <class G>
    Status check_layout(const G& v) {
        if (const Status s = check_.check(v); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        if (v.axis_count != N)
            return fail(ErrorCode::kInvalidParam, error("axis_count", "must equal the board's axis count (hello)"));
        for (std::size_t i = 0; i < kLayoutAxes; ++i)
            for (std::size_t j = 0; j < kLayoutAxes; ++j) {
                if (i < static_cast<std::size_t>(N) && j < static_cast<std::size_t>(N)) continue;
                if (!(v.gain[i * kLayoutAxes + j] == (i == j ? 1.0f : 0.0f)))
                    return fail(ErrorCode::kInvalidParam,
                                error("gain", static_cast<int>(i * kLayoutAxes + j),
                                      "outside the board's axes: must be the identity's (1 on the diagonal, else 0)"));
            }
        return ok_status();
    }
    static InputMatrix<N> input_matrix_of(const InputMatrixParams& v) {
        InputMatrix<N> m;
        for (int i = 0; i < N; ++i) {
            for (int j = 0; j < N; ++j) m.gain.m[i][j] = v.gain[i * kLayoutAxes + j];
            m.offset_um[i] = v.offset_um[i];
        }
        return m;
    }
    static AxisMatrix<N> output_matrix_of(const OutputMatrixParams& v) {
        AxisMatrix<N> m;
        for (int i = 0; i < N; ++i)
            for (int j = 0; j < N; ++j) m.m[i][j] = v.gain[i * kLayoutAxes + j];
        return m;
    }

    Status check(const InputMatrixParams& v) {
        if (const Status s = check_layout(v); !s.ok()) return s;
        for (std::size_t i = N; i < kLayoutAxes; ++i)
            if (!(v.offset_um[i] == 0.0f))
                return fail(ErrorCode::kInvalidParam,
                            error("offset_um", static_cast<int>(i), "outside the board's axes: must be 0"));
        const InputMatrix<N> m = input_matrix_of(v);
        if (const Status s = validate_input_matrix(m); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        if (!kMatrices && !(m == InputMatrix<N>{}))
            return fail(ErrorCode::kUnsupported,
                        error("gain", "this board has no input matrix stage: only the identity with offset 0"));
        return ok_status();
    }
    Status check(const OutputMatrixParams& v) {
        if (const Status s = check_layout(v); !s.ok()) return s;
        const AxisMatrix<N> m = output_matrix_of(v);
        if (const Status s = validate_output_matrix(m); !s.ok()) return fail(ErrorCode::kInvalidParam, s);
        if (!kMatrices && !m.is_identity())
            return fail(ErrorCode::kUnsupported,
                        error("gain", "this board has no output matrix stage: only the identity"));
        return ok_status();
    }

    Status apply(const InputMatrixParams& v) {
        if (v == input_params()) return ok_status();  // unchanged: nothing to take over
        if (const Status s = check(v); !s.ok()) return s;
        if constexpr (kMatrices) return taken(multi_->set_input_matrix(input_matrix_of(v)));
        return ok_status();
    }
    Status apply(const OutputMatrixParams& v) {
        if (v == output_params()) return ok_status();
        if (const Status s = check(v); !s.ok()) return s;
        if constexpr (kMatrices) return taken(multi_->set_output_matrix(output_matrix_of(v)));
        return ok_status();
    }
    // The core's refusal of a valid matrix: an axis armed, or the previous
    // matrix not yet taken over.
    Status taken(const Status& s) {
        if (s.ok()) return s;
        if constexpr (kMatrices) {
            if (multi_->any_armed()) return fail(ErrorCode::kArmed, s);
        }
        return fail(ErrorCode::kBusy, s);
    }

    RecorderType& recorder_;
    std::array<const PipelineSetup*, N> setups_;
    MultiPtr multi_;
    void (*mask_tick_)(bool) = nullptr;
    ErrorCode code_ = ErrorCode::kInvalidParam;
    LinkParams link_{};
    uint32_t client_timeout_ticks_ = timeout_ticks(LinkParams{}.client_timeout_s);
    params::FieldCheck check_{};
};

}  // namespace piezoloop::link
