// Figures, launched one way: a command writes what to draw as JSON and a
// script of tools/ (matplotlib, run by Debian's /usr/bin/python3, which has
// it) draws the PNGs: tools/plot_sim.py for time series (sim, record,
// reproduce), tools/plot.py for frequency-domain panels (analyze).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace piezoloop::sim {

// The repository root: $PIEZOLOOP_ROOT if set, else the source tree this
// binary was built from, else the current directory.
std::filesystem::path repository_root();

// Runs `/usr/bin/python3 tools/<script> <args...>` with the script's output
// on stderr (stdout carries the commands' JSON); throws std::runtime_error
// with the command and its exit status if it fails or is missing.
void run_plot_script(const std::string& script, const std::vector<std::string>& args);

// Writes spec to a temporary JSON file, runs tools/<script> on it followed
// by extra_args, and removes the file.
void plot_spec(const std::string& script, const nlohmann::json& spec, const std::vector<std::string>& extra_args = {});

}  // namespace piezoloop::sim
