#include "link/csv_log.hpp"

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "format/number.hpp"

namespace piezoloop::hostlink {

namespace {

std::vector<std::string> split_cells(const std::string& line) {
    std::vector<std::string> cells;
    std::string cell;
    std::stringstream ss(line);
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    if (cells.empty()) cells.emplace_back();
    return cells;
}

}  // namespace

std::vector<float> read_setpoints_csv(const std::string& path, const std::string& column) {
    std::ifstream f(path);
    if (!f) throw std::invalid_argument("--file: cannot read " + path);
    std::vector<float> out;
    std::string line;
    int col = -1;
    std::size_t line_no = 0;
    while (std::getline(f, line)) {
        ++line_no;
        if (line_no == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // UTF-8 byte-order mark
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty() || line[0] == '#') continue;
        const std::vector<std::string> cells = split_cells(line);
        if (col < 0) {
            char* end = nullptr;
            std::strtod(cells[0].c_str(), &end);
            const bool header = end == cells[0].c_str();
            if (header) {
                const std::vector<std::string> wanted =
                    column.empty() ? std::vector<std::string>{"setpoint_um", "r_um"} : std::vector<std::string>{column};
                for (const std::string& w : wanted)
                    for (std::size_t i = 0; i < cells.size() && col < 0; ++i)
                        if (cells[i] == w) col = static_cast<int>(i);
                if (col < 0 && !column.empty()) throw std::invalid_argument("--column: no column '" + column + "' in " + path);
                if (col < 0) col = 0;
                continue;
            }
            if (!column.empty()) throw std::invalid_argument("--column: " + path + " has no header line");
            col = 0;
        }
        if (static_cast<std::size_t>(col) >= cells.size())
            throw std::invalid_argument(path + ":" + std::to_string(line_no) + ": missing column " + std::to_string(col + 1));
        const std::string& cell = cells[static_cast<std::size_t>(col)];
        char* end = nullptr;
        const double v = std::strtod(cell.c_str(), &end);
        if (end == cell.c_str() || !std::isfinite(v))
            throw std::invalid_argument(path + ":" + std::to_string(line_no) + ": not a number");
        out.push_back(static_cast<float>(v));
    }
    if (out.empty()) throw std::invalid_argument("--file: no setpoints in " + path);
    return out;
}

CsvFile::CsvFile(std::string path) : path_(std::move(path)) {
    tmp_ = path_ + ".partial-" + std::to_string(::getpid());
    f_ = std::fopen(tmp_.c_str(), "w");
    if (f_ == nullptr) throw std::runtime_error("--out: cannot write " + tmp_ + ": " + std::strerror(errno));
}

CsvFile::~CsvFile() {
    if (f_ != nullptr) {
        std::fclose(f_);
        std::remove(tmp_.c_str());
    }
}

void CsvFile::comment(const std::string& text) { std::fprintf(f_, "# %s\n", text.c_str()); }

void CsvFile::header(const std::vector<std::string>& names) {
    for (std::size_t i = 0; i < names.size(); ++i) std::fprintf(f_, "%s%s", i ? "," : "", names[i].c_str());
    std::fputc('\n', f_);
}

void CsvFile::row(const std::vector<double>& values) {
    for (std::size_t i = 0; i < values.size(); ++i) {
        if (i) std::fputc(',', f_);
        std::fputs(format::significant(values[i], 9).c_str(), f_);
    }
    std::fputc('\n', f_);
}

void CsvFile::commit() {
    const bool ok = std::fflush(f_) == 0 && std::ferror(f_) == 0;
    std::fclose(f_);
    f_ = nullptr;
    if (!ok || std::rename(tmp_.c_str(), path_.c_str()) != 0) {
        const std::string why = std::strerror(errno);
        std::remove(tmp_.c_str());
        throw std::runtime_error("--out: cannot write " + path_ + ": " + why);
    }
}

}  // namespace piezoloop::hostlink
