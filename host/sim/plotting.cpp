#include "sim/plotting.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace piezoloop::sim {

std::filesystem::path repository_root() {
    if (const char* env = std::getenv("PIEZOLOOP_ROOT"); env && *env) return env;
#ifdef PIEZOLOOP_SOURCE_DIR
    // The source tree the binary was built from.
    if (std::filesystem::exists(std::filesystem::path(PIEZOLOOP_SOURCE_DIR) / "tools" / "plot_sim.py"))
        return PIEZOLOOP_SOURCE_DIR;
#endif
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

void run_plot_script(const std::string& script, const std::vector<std::string>& args) {
    const std::filesystem::path path = repository_root() / "tools" / script;
    if (!std::filesystem::exists(path))
        throw std::runtime_error("plot: " + path.string() + " not found (set PIEZOLOOP_ROOT to the repository)");
    std::string cmd = quote("/usr/bin/python3") + " " + quote(path.string());
    for (const std::string& a : args) cmd += " " + quote(a);
    cmd += " 1>&2";
    std::fflush(stdout);
    const int rc = std::system(cmd.c_str());
    if (rc != 0) {
        const int code = WIFEXITED(rc) ? WEXITSTATUS(rc) : rc;
        throw std::runtime_error("plot: `" + cmd + "` failed with status " + std::to_string(code));
    }
}

void plot_spec(const std::string& script, const nlohmann::json& spec, const std::vector<std::string>& extra_args) {
    char name[] = "/tmp/piezoloop-plot-XXXXXX";
    const int fd = ::mkstemp(name);
    if (fd < 0) throw std::runtime_error("plot: cannot create a temporary file");
    ::close(fd);
    struct Remove {
        const char* file;
        ~Remove() { std::remove(file); }
    } remove{name};
    {
        std::ofstream f(name);
        f << spec.dump();
        if (!f) throw std::runtime_error(std::string("plot: cannot write ") + name);
    }
    std::vector<std::string> args{name};
    args.insert(args.end(), extra_args.begin(), extra_args.end());
    run_plot_script(script, args);
}

}  // namespace piezoloop::sim
