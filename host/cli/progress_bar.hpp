// A progress bar on stderr for the measure commands: drawn on a terminal
// only, once the run has taken a second, ended with a newline at 100 %.
#pragma once

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

namespace piezoloop::cli {

inline void progress_bar(double fraction, std::chrono::steady_clock::time_point t0, bool& shown) {
    static const bool tty = isatty(STDERR_FILENO) != 0;
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!tty || (el < 1.0 && !shown)) return;
    const int filled = static_cast<int>(fraction * 40 + 0.5);
    std::string bar(static_cast<size_t>(filled), '#');
    bar.resize(40, ' ');
    std::fprintf(stderr, "\r[%s] %3.0f%% ", bar.c_str(), 100.0 * fraction);
    shown = true;
    if (fraction >= 1.0) std::fprintf(stderr, "\n");
}

}  // namespace piezoloop::cli
