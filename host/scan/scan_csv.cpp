#include "scan/scan_csv.hpp"

#include <cstdio>
#include <memory>
#include <stdexcept>

namespace piezoloop::scan {

void write_scan_csv(const std::filesystem::path& file, const std::vector<ScanTick>& ticks) {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(file.c_str(), "w"), &std::fclose);
    if (!f) throw std::runtime_error(file.string() + ": cannot be written");
    std::fputs("tick,commanded_x_um,commanded_y_um,measured_x_um,measured_y_um,true_x_um,true_y_um,height_nm,sync\n",
               f.get());
    for (std::size_t k = 0; k < ticks.size(); ++k) {
        const ScanTick& t = ticks[k];
        std::fprintf(f.get(), "%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%u\n", k, t.commanded_x_um, t.commanded_y_um,
                     t.measured_x_um, t.measured_y_um, t.true_x_um, t.true_y_um, t.height_nm, t.sync);
    }
    if (std::ferror(f.get())) throw std::runtime_error(file.string() + ": write failed");
}

}  // namespace piezoloop::scan
