#include "scan/scan_pixels.hpp"

#include <algorithm>
#include <map>

#include "piezoloop/scan/scan_config.hpp"

namespace piezoloop::scan {

uint32_t usual_pixel_ticks(const std::vector<ScanTick>& ticks) {
    std::map<std::size_t, std::size_t> count;  // gap -> how often
    std::size_t last = 0;
    bool seen = false;
    for (std::size_t k = 0; k < ticks.size(); ++k) {
        if ((ticks[k].sync & kSyncPixel) == 0) continue;
        if (seen) ++count[k - last];
        last = k;
        seen = true;
    }
    std::size_t best = 0, best_n = 0;
    for (const auto& [gap, n] : count)
        if (n > best_n) best = gap, best_n = n;  // ties: the shorter gap
    return static_cast<uint32_t>(best);
}

std::vector<ScanPixel> form_pixels(const std::vector<ScanTick>& ticks) {
    std::vector<ScanPixel> out;
    const std::size_t usual = usual_pixel_ticks(ticks);
    std::vector<std::size_t> clocks;
    for (std::size_t k = 0; k < ticks.size(); ++k)
        if (ticks[k].sync & kSyncPixel) clocks.push_back(k);
    if (clocks.empty()) return out;
    const std::size_t len_one = usual == 0 ? ticks.size() : usual;

    uint32_t frame = 0, line = 0, index = 0;
    bool any_frame = false, any_line = false;
    std::size_t c = 0;
    for (std::size_t k = 0; k < ticks.size() && c < clocks.size(); ++k) {
        const uint32_t s = ticks[k].sync;
        if (s & kSyncFrameStart) {
            if (any_frame) ++frame;
            any_frame = true;
            line = 0;
            any_line = false;
            index = 0;
        }
        if (s & kSyncLineStart) {
            if (any_line) ++line;
            any_line = true;
            index = 0;
        }
        if (k != clocks[c]) continue;
        const std::size_t next = c + 1 < clocks.size() ? clocks[c + 1] : ticks.size();
        const std::size_t n = std::min(next - k, len_one);
        ScanPixel p;
        p.frame = frame;
        p.line = line;
        p.index = index++;
        p.first_tick = k;
        p.ticks = static_cast<uint32_t>(n);
        for (std::size_t j = k; j < k + n; ++j) {
            const ScanTick& t = ticks[j];
            p.commanded_x_um += t.commanded_x_um;
            p.commanded_y_um += t.commanded_y_um;
            p.measured_x_um += t.measured_x_um;
            p.measured_y_um += t.measured_y_um;
            p.true_x_um += t.true_x_um;
            p.true_y_um += t.true_y_um;
            p.height_nm += t.height_nm;
        }
        const double inv = 1.0 / static_cast<double>(n);
        p.commanded_x_um *= inv;
        p.commanded_y_um *= inv;
        p.measured_x_um *= inv;
        p.measured_y_um *= inv;
        p.true_x_um *= inv;
        p.true_y_um *= inv;
        p.height_nm *= inv;
        out.push_back(p);
        ++c;
    }
    return out;
}

}  // namespace piezoloop::scan
