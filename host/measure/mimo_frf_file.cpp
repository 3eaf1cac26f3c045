#include "measure/mimo_frf_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "format/number.hpp"

namespace piezoloop::measure {

namespace {

constexpr const char* kMagic = "# piezoloop mimo-frf 1";

std::string element(int i, int j) { return "G" + std::to_string(i + 1) + std::to_string(j + 1); }

std::string full(double x) {
    if (std::isnan(x)) return "nan";
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", x);
    return buf;
}

[[noreturn]] void bad(const std::string& file, int line, const std::string& field, const std::string& why) {
    throw std::invalid_argument(file + ": line " + std::to_string(line) + ": " + field + ": " + why);
}

// A whole cell as a double ("nan" allowed only where said).
bool parse_number(const std::string& cell, double& out) {
    if (cell == "nan") {
        out = std::numeric_limits<double>::quiet_NaN();
        return true;
    }
    if (cell.empty()) return false;
    std::size_t used = 0;
    try {
        out = std::stod(cell, &used);
    } catch (const std::exception&) {
        return false;
    }
    return used == cell.size() && std::isfinite(out);
}

std::vector<std::string> split(const std::string& s) {
    std::vector<std::string> cells;
    std::stringstream ss(s);
    std::string c;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    if (!s.empty() && s.back() == ',') cells.emplace_back();
    return cells;
}

}  // namespace

std::string mimo_frf_columns(int inputs, int outputs) {
    std::string s = "f_Hz";
    for (int i = 0; i < outputs; ++i)
        for (int j = 0; j < inputs; ++j)
            for (const char* part : {"_re", "_im", "_std"}) s += "," + element(i, j) + part;
    return s;
}

void write_mimo_frf(const std::string& path, const MimoFrfEstimate& e) {
    std::ofstream f(path);
    f << kMagic << "\n# inputs=" << e.inputs << " outputs=" << e.outputs << " rate_Hz=" << full(e.rate_Hz)
      << " periods=" << e.periods << "\n"
      << mimo_frf_columns(e.inputs, e.outputs) << "\n";
    for (std::size_t k = 0; k < e.frequency_Hz.size(); ++k) {
        f << full(e.frequency_Hz[k]);
        for (int i = 0; i < e.outputs; ++i)
            for (int j = 0; j < e.inputs; ++j)
                f << ',' << full(e.response[k](i, j).real()) << ',' << full(e.response[k](i, j).imag()) << ','
                  << full(e.std_dev[k](i, j));
        f << "\n";
    }
    if (!f) throw std::runtime_error("cannot write " + path);
}

MimoFrfEstimate load_mimo_frf_file(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::invalid_argument(path + ": cannot read the file");
    std::string line;
    if (!std::getline(in, line) || line != kMagic)
        bad(path, 1, "header", std::string("must be \"") + kMagic + "\" (a MIMO frequency response file)");
    if (!std::getline(in, line) || line.rfind("# ", 0) != 0)
        bad(path, 2, "header", "must be \"# inputs=N outputs=M rate_Hz=R periods=P\"");
    MimoFrfEstimate e;
    {
        std::stringstream ss(line.substr(2));
        std::string kv;
        bool have[4] = {false, false, false, false};
        while (ss >> kv) {
            const std::size_t eq = kv.find('=');
            const std::string key = kv.substr(0, eq), value = eq == std::string::npos ? "" : kv.substr(eq + 1);
            double x = 0.0;
            if (!parse_number(value, x) || std::isnan(x)) bad(path, 2, key, "must be key=number (got \"" + kv + "\")");
            if (key == "inputs" || key == "outputs") {
                if (x != std::floor(x) || x < 1 || x > 16) bad(path, 2, key, "must be an integer in [1, 16]");
                (key == "inputs" ? e.inputs : e.outputs) = static_cast<int>(x);
                have[key == "inputs" ? 0 : 1] = true;
            } else if (key == "rate_Hz") {
                if (!(x > 0.0)) bad(path, 2, key, "must be > 0 Hz");
                e.rate_Hz = x;
                have[2] = true;
            } else if (key == "periods") {
                if (x != std::floor(x) || x < 1 || x > 10000) bad(path, 2, key, "must be an integer in [1, 10000]");
                e.periods = static_cast<int>(x);
                have[3] = true;
            } else {
                bad(path, 2, key, "unknown field (inputs, outputs, rate_Hz, periods)");
            }
        }
        const char* names[4] = {"inputs", "outputs", "rate_Hz", "periods"};
        for (int q = 0; q < 4; ++q)
            if (!have[q]) bad(path, 2, names[q], "missing");
    }
    const std::string columns = mimo_frf_columns(e.inputs, e.outputs);
    if (!std::getline(in, line)) bad(path, 3, "columns", "missing: must be \"" + columns + "\"");
    if (line != columns) {
        const std::vector<std::string> got = split(line), want = split(columns);
        for (std::size_t c = 0; c < std::max(got.size(), want.size()); ++c)
            if (c >= got.size() || c >= want.size() || got[c] != want[c])
                bad(path, 3, "column " + std::to_string(c + 1),
                    (c < got.size() ? "is \"" + got[c] + "\"" : std::string("is missing")) + ", inputs=" +
                        std::to_string(e.inputs) + " outputs=" + std::to_string(e.outputs) + " need " +
                        (c < want.size() ? "\"" + want[c] + "\"" : "no more than " + std::to_string(want.size()) +
                                                                      " columns") +
                        " (the columns: " + columns + ")");
    }
    const std::size_t cells = 1 + 3 * static_cast<std::size_t>(e.inputs) * static_cast<std::size_t>(e.outputs);
    int number = 3;
    while (std::getline(in, line)) {
        ++number;
        if (line.empty()) continue;
        const std::vector<std::string> row = split(line);
        if (row.size() != cells)
            bad(path, number, "row", "must have " + std::to_string(cells) + " values (got " + std::to_string(row.size()) +
                                         ")");
        double f_Hz = 0.0;
        if (!parse_number(row[0], f_Hz) || std::isnan(f_Hz)) bad(path, number, "f_Hz", "must be a finite number");
        if (!(f_Hz > 0.0 && f_Hz <= e.rate_Hz / 2.0))
            bad(path, number, "f_Hz", "must be in (0, " + format::significant(e.rate_Hz / 2.0) + "] Hz, rate_Hz / 2 (got " +
                                          format::significant(f_Hz) + ")");
        if (!e.frequency_Hz.empty() && !(f_Hz > e.frequency_Hz.back()))
            bad(path, number, "f_Hz", "must increase line by line (" + format::significant(f_Hz, 10) + " after " +
                                          format::significant(e.frequency_Hz.back(), 10) + ")");
        Eigen::MatrixXcd g(e.outputs, e.inputs);
        Eigen::MatrixXd sd(e.outputs, e.inputs), snr(e.outputs, e.inputs);
        std::size_t c = 1;
        for (int i = 0; i < e.outputs; ++i)
            for (int j = 0; j < e.inputs; ++j) {
                double re = 0.0, im = 0.0, s = 0.0;
                const std::string name = element(i, j);
                if (!parse_number(row[c], re) || std::isnan(re)) bad(path, number, name + "_re", "must be a finite number");
                if (!parse_number(row[c + 1], im) || std::isnan(im))
                    bad(path, number, name + "_im", "must be a finite number");
                if (!parse_number(row[c + 2], s) || s < 0.0)
                    bad(path, number, name + "_std", "must be a finite number >= 0 or nan (unknown)");
                c += 3;
                g(i, j) = {re, im};
                sd(i, j) = s;
                snr(i, j) = 20.0 * std::log10(std::abs(g(i, j)) / s);
            }
        e.frequency_Hz.push_back(f_Hz);
        e.response.push_back(g);
        e.std_dev.push_back(sd);
        e.snr_db.push_back(snr);
    }
    if (e.frequency_Hz.empty()) bad(path, number + 1, "f_Hz", "no lines: at least one row of values");
    return e;
}

nlohmann::json mimo_frf_summary(const MimoFrfEstimate& e) {
    nlohmann::json j;
    j["inputs"] = e.inputs;
    j["outputs"] = e.outputs;
    j["rate_Hz"] = e.rate_Hz;
    j["periods"] = e.periods;
    j["lines"] = e.frequency_Hz.size();
    if (!e.frequency_Hz.empty()) j["band_Hz"] = {e.frequency_Hz.front(), e.frequency_Hz.back()};
    nlohmann::json elements = nlohmann::json::array();
    for (int i = 0; i < e.outputs; ++i)
        for (int jj = 0; jj < e.inputs; ++jj) {
            std::vector<double> snr;
            for (const Eigen::MatrixXd& s : e.snr_db)
                if (!std::isnan(s(i, jj))) snr.push_back(s(i, jj));
            nlohmann::json el = {{"element", element(i, jj)}};
            if (snr.empty()) {
                el["min_snr_db"] = nullptr;
                el["median_snr_db"] = nullptr;
            } else {
                std::sort(snr.begin(), snr.end());
                // An infinite SNR (no spread at all) is written as null.
                auto finite = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
                el["min_snr_db"] = finite(snr.front());
                el["median_snr_db"] = finite(snr[snr.size() / 2]);
            }
            elements.push_back(el);
        }
    j["elements"] = elements;
    if (!e.input_condition.empty())
        j["max_input_condition"] = *std::max_element(e.input_condition.begin(), e.input_condition.end());
    return j;
}

void write_mimo_frf_summary(const std::string& path, const MimoFrfEstimate& e) {
    std::ofstream f(path);
    f << mimo_frf_summary(e).dump(1) << "\n";
    if (!f) throw std::runtime_error("cannot write " + path);
}

}  // namespace piezoloop::measure
