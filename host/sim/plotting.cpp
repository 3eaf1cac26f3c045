#include "sim/plotting.hpp"

#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <sys/wait.h>

namespace piezoloop::sim {

std::filesystem::path repository_root() {
    if (const char* env = std::getenv("PIEZOLOOP_ROOT"); env && *env) return env;
    // This file is host/sim/plotting.cpp in the tree the binary was built from.
    const std::filesystem::path here(__FILE__);
    if (here.is_absolute()) {
        const std::filesystem::path root = here.parent_path().parent_path().parent_path();
        if (std::filesystem::exists(root / "tools" / "plot_sim.py")) return root;
    }
    return std::filesystem::current_path();
}

namespace {

std::string quote(const std::string& s) {
    std::string q = "'";
    for (const char c : s) {
        if (c == '\'') q += "'\\''";
        else q += c;
    }
    return q + "'";
}

}  // namespace

void run_plot_script(const std::filesystem::path& spec_json, const std::string& python) {
    const std::filesystem::path script = repository_root() / "tools" / "plot_sim.py";
    if (!std::filesystem::exists(script))
        throw std::runtime_error("plot: " + script.string() + " not found (set PIEZOLOOP_ROOT to the repository)");
    // Its messages go to stderr: stdout carries the commands' JSON.
    const std::string cmd = quote(python) + " " + quote(script.string()) + " " + quote(spec_json.string()) + " 1>&2";
    std::fflush(stdout);
    const int rc = std::system(cmd.c_str());
    if (rc != 0) {
        const int code = WIFEXITED(rc) ? WEXITSTATUS(rc) : rc;
        throw std::runtime_error("plot: `" + cmd + "` failed with status " + std::to_string(code));
    }
}

std::string hex64(unsigned long long h) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", h);
    return buf;
}

}  // namespace piezoloop::sim
