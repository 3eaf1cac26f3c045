// Runs the reference closed loop (common/piezoloop/reference_run.hpp) with
// this board's core sample type and prints its log hash, which the host test
// compares with the host build's:
//   reference board=<board> sample=<float|q31> ticks=<n> log_hash=<hex64> e_max_nm=<n>
#include "app/core_sample.hpp"
#include "bsp/bsp.hpp"
#include "bsp/text.hpp"
#include "piezoloop/reference_run.hpp"

namespace {

using Sample = piezoloop::fw::CoreSample;
// Static storage: the pipeline (two banks with their RC delay lines, and the
// recorder) is far larger than a tick's stack frame should be.
piezoloop::Pipeline<Sample, 1024, 4, 1024> g_pipeline{piezoloop::reference::setup()};
piezoloop::HammersteinPlant g_plant;

}  // namespace

int app_main() {
    const auto res = piezoloop::reference::run_closed_loop<Sample>(g_pipeline, g_plant,
                                                                   piezoloop::reference::kHashTicks);
    piezoloop::bsp::TextLine line;
    line.str("reference board=").str(piezoloop::bsp::kBoardName);
    line.key("sample").str(piezoloop::fw::kCoreSampleName);
    line.key("ticks").udec(res.ticks);
    line.key("log_hash").hex64(res.log_hash);
    line.key("e_max_nm").dec(static_cast<int64_t>(res.e_max_um * 1000.0f));
    line.flush();
    return res.ticks == piezoloop::reference::kHashTicks ? 0 : 1;
}
