// A run of the float-fidelity simulator as raw bytes: the core's parameter
// structs exactly as configured, so that a separately compiled program
// (tests/host/sim/sim_hash_probe.cpp, built at -O0 and -O2) can replay the very
// same loop and print its log hash. Header-only, core types only. The bytes
// are only meaningful to programs built by the same compiler for the same
// target (the cross-build determinism check), not a file format.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <type_traits>
#include <vector>

#include "piezoloop/pipeline.hpp"
#include "piezoloop/stage_model.hpp"

namespace piezoloop::sim {

struct ModelDump {
    PipelineSetup setup{};
    PipelineParams params{};
    uint32_t q31 = 0;  // 1: Pipeline<Q31>
    StageConfig stage{};
    TrajectoryConfig wave{};  // table span cleared; values in `table`
    uint64_t ticks = 0;
    std::vector<float> table;
};

namespace dump_detail {
inline constexpr char kMagic[8] = {'P', 'L', 'S', 'I', 'M', '0', '2', '\n'};

template <class T>
void put(std::vector<unsigned char>& out, const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    // resize + memcpy, not insert: GCC 12 reports a false -Warray-bounds on
    // vector::insert's reallocation path here (GCC bug 107852).
    const std::size_t at = out.size();
    out.resize(at + sizeof(T));
    std::memcpy(out.data() + at, &v, sizeof(T));
}
template <class T>
bool get(const unsigned char*& p, const unsigned char* end, T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (static_cast<size_t>(end - p) < sizeof(T)) return false;
    std::memcpy(&v, p, sizeof(T));
    p += sizeof(T);
    return true;
}
}  // namespace dump_detail

inline std::vector<unsigned char> serialise(const ModelDump& d) {
    using dump_detail::put;
    std::vector<unsigned char> out(dump_detail::kMagic, dump_detail::kMagic + 8);
    TrajectoryConfig w = d.wave;
    w.table = {};
    put(out, d.setup);
    put(out, d.params);
    put(out, d.q31);
    put(out, d.stage);
    put(out, w);
    put(out, d.ticks);
    put(out, static_cast<uint64_t>(d.table.size()));
    for (const float f : d.table) put(out, f);
    return out;
}

inline bool deserialise(const std::vector<unsigned char>& in, ModelDump& d) {
    using dump_detail::get;
    if (in.size() < 8 || std::memcmp(in.data(), dump_detail::kMagic, 8) != 0) return false;
    const unsigned char* p = in.data() + 8;
    const unsigned char* end = in.data() + in.size();
    uint64_t n = 0;
    if (!get(p, end, d.setup) || !get(p, end, d.params) || !get(p, end, d.q31) || !get(p, end, d.stage) ||
        !get(p, end, d.wave) || !get(p, end, d.ticks) || !get(p, end, n))
        return false;
    d.table.resize(n);
    for (float& f : d.table)
        if (!get(p, end, f)) return false;
    d.wave.table = {};
    return p == end;
}

}  // namespace piezoloop::sim
