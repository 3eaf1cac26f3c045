// The reference tick written the straightforward way, to measure the
// pipeline against (bench_pipeline.cpp, profile_pipeline.cpp).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "piezoloop/pipeline.hpp"

namespace bench {

// The same tick, written the straightforward way: float, std::vector and
// plain arrays, direct form I sections, a delay line indexed modulo N, clamp
// then slew, frames into a ring. No templates, no Q31, nothing precomputed
// beyond what any implementation configures once (the inverse PI model, float
// coefficients). Same order of operations as the pipeline's tick:
//   e = r - y; u_ff = PI^-1(r); u_rc = RC(e); u_fb = C(e + u_rc);
//   u = limit(u_ff + u_fb); record (r, y, e, u).
namespace straightforward {

using piezoloop::PiModel;
using piezoloop::PipelineParams;
using piezoloop::PipelineSetup;
using piezoloop::SosSection;

struct Biquad {  // direct form I
    float b[3] = {1.0f, 0.0f, 0.0f};
    float a[3] = {1.0f, 0.0f, 0.0f};
    float x[2] = {0.0f, 0.0f};
    float y[2] = {0.0f, 0.0f};

    float step(float in) {
        const float out = b[0] * in + b[1] * x[0] + b[2] * x[1] - a[1] * y[0] - a[2] * y[1];
        x[1] = x[0];
        x[0] = in;
        y[1] = y[0];
        y[0] = out;
        return out;
    }
    void reset() { x[0] = x[1] = y[0] = y[1] = 0.0f; }
};

Biquad biquad_from(const SosSection& s) {
    Biquad q;
    q.b[0] = static_cast<float>(s.b0);
    q.b[1] = static_cast<float>(s.b1);
    q.b[2] = static_cast<float>(s.b2);
    q.a[1] = static_cast<float>(s.a1);
    q.a[2] = static_cast<float>(s.a2);
    return q;
}

struct Frame {
    uint32_t tick;
    float value[4];
};

class Controller {
public:
    Controller(const PipelineParams& p, const PipelineSetup& setup) {
        // Inverse of the stage's PI model (Janaideh2016 eq. 44-45), in double:
        // thresholds z_j = phi(r_j), weights -p_j / (P_j P_{j-1}), P_j the
        // slope of the loading curve after r_j.
        const PiModel& m = p.pi;
        p0_inv = static_cast<float>(1.0 / m.p0);
        double slope_prev = m.p0, r_prev = 0.0, z_prev = 0.0;
        for (int j = 0; j < m.count; ++j) {
            const double r = m.thresholds[static_cast<unsigned>(j)];
            const double w = m.weights[static_cast<unsigned>(j)];
            const double slope = slope_prev + w;
            const double z = z_prev + slope_prev * (r - r_prev);
            thresholds.push_back(static_cast<float>(z));
            weights.push_back(static_cast<float>(-w / (slope * slope_prev)));
            slope_prev = slope;
            r_prev = r;
            z_prev = z;
        }
        play_state.assign(thresholds.size(), 0.0f);
        for (int i = 0; i < p.sos_count; ++i) sections.push_back(biquad_from(p.sos[static_cast<unsigned>(i)]));
        period = p.rc.period_samples;
        m1 = p.rc.m1;
        m2 = p.rc.m2;
        k_rc = p.rc.k_rc;
        q_generator = biquad_from(p.rc.q);
        q_output = biquad_from(p.rc.q);
        delay.assign(static_cast<std::size_t>(period), 0.0f);
        u_min = p.limits.u_min_V;
        u_max = p.limits.u_max_V;
        slew_step = p.limits.slew_V_per_s / setup.rate_Hz;
    }

    // What the pipeline's restart (one tick disarmed, then armed) does:
    // controller states from rest, and the output one slew step towards 0 V.
    void restart() {
        u_last = u_last + std::clamp(0.0f - u_last, -slew_step, slew_step);
        std::fill(play_state.begin(), play_state.end(), 0.0f);
        for (Biquad& s : sections) s.reset();
        q_generator.reset();
        q_output.reset();
        std::fill(delay.begin(), delay.end(), 0.0f);
        pos = 0;
    }

    float tick(float r, float y) {
        const float e = r - y;

        // Feedforward: inverse PI model of the stage.
        float uff = p0_inv * r;
        for (std::size_t j = 0; j < thresholds.size(); ++j) {
            play_state[j] = std::max(r - thresholds[j], std::min(r + thresholds[j], play_state[j]));
            uff += weights[j] * play_state[j];
        }

        // Repetitive control: s[k] = e[k] + X[k], X[k] = Q{s[k - (N - m1)]},
        // u_rc[k] = k_rc Q{s[k - (N - m1 - m2)]}.
        const float x = q_generator.step(delay[(pos + period - (period - m1)) % period]);
        const float lead = q_output.step(delay[(pos + period - (period - m1 - m2)) % period]);
        delay[pos] = e + x;
        pos = (pos + 1) % period;
        const float urc = k_rc * lead;

        // Feedback: the cascade on e + u_rc.
        float ufb = e + urc;
        for (Biquad& s : sections) ufb = s.step(ufb);

        // Limits: clamp to the range, then at most one slew step.
        const float target = std::clamp(uff + ufb, u_min, u_max);
        const float d = std::clamp(target - u_last, -slew_step, slew_step);
        u_last = u_last + d;

        // Recorder: r, y, e, u into the ring, dropping the frame if it is full.
        if (head - tail < ring.size()) {
            ring[head % ring.size()] = Frame{tick_count, {r, y, e, u_last}};
            ++head;
        } else {
            ++overruns;
        }
        ++tick_count;
        last_uff = uff;
        last_ufb = ufb;
        return u_last;
    }

    std::size_t drain(std::span<Frame> out) {
        std::size_t n = 0;
        while (tail != head && n < out.size()) out[n++] = ring[tail++ % ring.size()];
        return n;
    }

    float last_uff = 0.0f, last_ufb = 0.0f;
    std::size_t overruns = 0;

private:
    float p0_inv = 1.0f;
    std::vector<float> thresholds, weights, play_state;
    std::vector<Biquad> sections;
    int period = 1, m1 = 0, m2 = 0;
    float k_rc = 0.0f;
    Biquad q_generator, q_output;
    std::vector<float> delay;
    int pos = 0;
    float u_min = 0.0f, u_max = 0.0f, slew_step = 0.0f, u_last = 0.0f;
    std::array<Frame, 1024> ring{};
    std::size_t head = 0, tail = 0;
    uint32_t tick_count = 0;
};

}  // namespace straightforward

}  // namespace bench
