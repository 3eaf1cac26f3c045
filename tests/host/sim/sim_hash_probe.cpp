// Replays a float-fidelity run dumped by `piezoloop sim --dump-model FILE`
// and prints its log hash (16 hex digits). tests/CMakeLists.txt builds this
// file twice, at -O0 and at -O2 (both with the core's -ffp-contract=off),
// apart from the piezoloop executable (-O3): equal hashes show that the
// simulated loop does not depend on how the same code was compiled
// (docs/architecture.md, "Determinism"). Uses the core and sim/loop_kernel.hpp only.
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <vector>

#include "piezoloop/reference_run.hpp"
#include "piezoloop/stage_model.hpp"
#include "sim/loop_kernel.hpp"
#include "sim/model_dump.hpp"

using namespace piezoloop;

namespace {

template <class T>
int replay(const sim::ModelDump& d) {
    auto pipe = std::make_unique<Pipeline<T, 16384>>(d.setup);
    StageModel stage;
    if (!stage.configure(d.stage).ok() || !pipe->stage(d.params).ok()) {
        std::fprintf(stderr, "sim_hash_probe: the dumped parameters are rejected\n");
        return 2;
    }
    TrajectoryConfig w = d.wave;
    if (!d.table.empty()) w.table = d.table;
    if (!pipe->start_wave(w).ok()) {
        std::fprintf(stderr, "sim_hash_probe: the dumped trajectory is rejected\n");
        return 2;
    }
    pipe->arm();
    reference::LogHash hash;
    sim::run_ticks<T>(*pipe, stage, d.stage.sensor.gain, d.ticks, &hash,
                      [](const sim::TickView&, const TickSignals<T>&, const StageModel&) {});
    std::printf("%016llx\n", static_cast<unsigned long long>(hash.value()));
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: sim_hash_probe DUMP\n");
        return 2;
    }
    std::ifstream f(argv[1], std::ios::binary);
    const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    sim::ModelDump d;
    if (!sim::deserialise(bytes, d)) {
        std::fprintf(stderr, "sim_hash_probe: %s is not a dump of this build\n", argv[1]);
        return 2;
    }
    return d.q31 ? replay<Q31>(d) : replay<float>(d);
}
