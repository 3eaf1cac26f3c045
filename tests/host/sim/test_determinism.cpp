// Determinism of the float (and Q31) simulation: the same run twice gives
// bit-identical logs (equal log hashes and equal samples); the hash moves
// when anything in the loop moves. The cross-build half (the same loop
// compiled at -O0 and -O2 apart from this binary) is tests/host/cli/check_sim.py
// with tests/host/sim/sim_hash_probe.cpp; here the in-process replay through the
// dump format is checked, which that test relies on.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>

#include "piezoloop/reference_run.hpp"
#include "sim/build_case.hpp"
#include "sim/experiments.hpp"
#include "sim/loop_kernel.hpp"
#include "sim/model_dump.hpp"
#include "sim/scenario.hpp"

using namespace piezoloop;
using namespace piezoloop::sim;

namespace {

const std::string kConfigs = std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../configs/";

struct Prepared {
    Scenario s;
    BuiltCase b;
    RunOptions o;
};

Prepared prepare(const char* scenario, const char* c, double f, double range_um, SampleType sample) {
    Prepared p{load_scenario(kConfigs + scenario + ".json"), {}, {}};
    CaseSpec cs = p.s.find_case(c);
    cs.sample = sample;
    BuildOptions bo;
    bo.reference_frequency_Hz = f;
    bo.check_realisation = false;
    p.b = build_case(p.s, cs, bo);
    TrajectoryRequest t;
    t.frequency_Hz = f;
    t.range_um = range_um;
    t.periods = 3;
    p.o = plan_run(p.s.rate_Hz, t, 0, false);
    p.o.log_start = 0;
    p.o.log_every = 1;
    return p;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

}  // namespace

TEST(SimDeterminism, TwoRunsAreBitIdentical) {
    for (const SampleType st : {SampleType::kFloat, SampleType::kQ31}) {
        const Prepared p = prepare("shan2012", "pi_rc", 1000.0, 10.0, st);
        const RunResult a = run_loop(p.b.model, p.o);
        const RunResult b = run_loop(p.b.model, p.o);
        EXPECT_EQ(a.log_hash, b.log_hash) << to_string(st);
        EXPECT_TRUE(same_bits(a.log.y_um, b.log.y_um)) << to_string(st);
        EXPECT_TRUE(same_bits(a.log.u_V, b.log.u_V)) << to_string(st);
    }
}

TEST(SimDeterminism, HashFollowsEveryChange) {
    Prepared p = prepare("shan2012", "pi_rc", 1000.0, 10.0, SampleType::kFloat);
    const uint64_t h0 = run_loop(p.b.model, p.o).log_hash;
    // Other noise: Shan2012's 0.06 mV rms is a fifth of an ADC step and
    // may not move a single code in 300 ticks, so both runs get 1 mV rms.
    LoopModel m = p.b.model;
    m.stage.sensor.noise_rms = 1e-3f;
    const uint64_t noisy = run_loop(m, p.o).log_hash;
    m.stage.sensor.seed += 1;
    EXPECT_NE(run_loop(m, p.o).log_hash, noisy);
    EXPECT_NE(noisy, h0);
    m = p.b.model;
    m.params.rc.k_rc = 0.7f;  // other controller
    EXPECT_NE(run_loop(m, p.o).log_hash, h0);
    m = p.b.model;
    m.sample = SampleType::kQ31;  // other core
    EXPECT_NE(run_loop(m, p.o).log_hash, h0);
    // Other stage (same hash fold). Shan2012's two fidelities agree to an
    // ADC step and may read the same codes for 300 ticks; Janaideh2016's
    // differ by its sensor lag (Tustin in float, exact in double).
    Prepared j = prepare("janaideh2016", "ff_fb", 10.0, 40.0, SampleType::kFloat);
    const uint64_t j_float = run_loop(j.b.model, j.o).log_hash;
    j.o.fidelity = Fidelity::kDouble;
    EXPECT_NE(run_loop(j.b.model, j.o).log_hash, j_float);
}

// The replay path of tests/host/sim/sim_hash_probe.cpp, in this binary: the dump
// round trip and run_ticks alone give the simulator's hash (Dahl
// feedforward, float, Ahmad2020 at 10 kHz; series inverse, Shan2012).
TEST(SimDeterminism, DumpReplayGivesTheSameHash) {
    for (const auto& [scen, c, f] : {std::tuple{"ahmad2020", "dahl_ff_K", 20.0}, std::tuple{"shan2012", "pi_rc_inv", 1000.0}}) {
        const Prepared p = prepare(scen, c, f, 8.0, SampleType::kFloat);
        const RunResult r = run_loop(p.b.model, p.o);
        ModelDump d;
        d.setup = p.b.model.setup;
        d.params = p.b.model.params;
        d.stage = p.b.model.stage;
        d.stage.rate_Hz = d.setup.rate_Hz;
        d.wave = p.o.wave;
        d.wave.sample_rate_Hz = d.setup.rate_Hz;
        d.ticks = p.o.ticks;
        ModelDump back;
        ASSERT_TRUE(deserialise(serialise(d), back));
        auto pipe = std::make_unique<Pipeline<float, kSimRcCapacity>>(back.setup);
        StageModel stage;
        ASSERT_TRUE(stage.configure(back.stage).ok());
        ASSERT_TRUE(pipe->stage(back.params).ok());
        ASSERT_TRUE(pipe->start_wave(back.wave).ok());
        pipe->arm();
        reference::LogHash h;
        run_ticks<float>(*pipe, stage, back.stage.sensor.gain, back.ticks, &h,
                         [](const TickView&, const TickSignals<float>&, const StageModel&) {});
        EXPECT_EQ(h.value(), r.log_hash) << scen;
        // A truncated dump is refused.
        std::vector<unsigned char> bytes = serialise(d);
        bytes.pop_back();
        EXPECT_FALSE(deserialise(bytes, back));
    }
}
