// Host side of the cross-platform determinism check: runs the reference
// closed loop (common/piezoloop/reference_run.hpp) in float or Q31 and prints
// the same fields the reference_hash firmware image prints.
//   host_reference_hash float|q31
#include <cstdio>
#include <cstring>
#include <memory>

#include "piezoloop/reference_run.hpp"

namespace {

template <class T>
int run(const char* name) {
    auto pipe = std::make_unique<piezoloop::Pipeline<T, 1024, 4, 1024>>(piezoloop::reference::setup());
    piezoloop::HammersteinPlant plant;
    const auto res = piezoloop::reference::run_closed_loop<T>(*pipe, plant, piezoloop::reference::kHashTicks);
    std::printf("reference board=host sample=%s ticks=%u log_hash=0x%016llx e_max_nm=%lld\n", name, res.ticks,
                static_cast<unsigned long long>(res.log_hash), static_cast<long long>(res.e_max_um * 1000.0f));
    return res.ticks == piezoloop::reference::kHashTicks ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc == 2 && std::strcmp(argv[1], "float") == 0) return run<float>("float");
    if (argc == 2 && std::strcmp(argv[1], "q31") == 0) return run<piezoloop::Q31>("q31");
    std::fprintf(stderr, "usage: %s float|q31\n", argv[0]);
    return 2;
}
