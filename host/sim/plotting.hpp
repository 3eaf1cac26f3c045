// Figures: the simulator writes its data as JSON and tools/plot_sim.py
// (matplotlib, run by Debian's /usr/bin/python3) draws the PNGs.
#pragma once

#include <filesystem>
#include <string>

namespace piezoloop::sim {

// The repository root: $PIEZOLOOP_ROOT if set, else the source tree this
// binary was built from, else the current directory.
std::filesystem::path repository_root();

// Runs `python tools/plot_sim.py <spec.json>`; throws std::runtime_error with
// the command and its exit status if it fails. python defaults to
// /usr/bin/python3 (the interpreter with matplotlib, see docs/architecture.md).
void run_plot_script(const std::filesystem::path& spec_json, const std::string& python = "/usr/bin/python3");

// Hex string of a 64-bit hash, 16 digits.
std::string hex64(unsigned long long h);

}  // namespace piezoloop::sim
