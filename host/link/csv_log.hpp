// CSV files of the link's records and streams: the setpoint column a
// `stream --file` sends, and a record written so that a file at its path is
// always either complete or marked incomplete.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace piezoloop::hostlink {

// The setpoints (um) of a CSV file: the named column, else setpoint_um or
// r_um, else the first; '#' lines are comments, a UTF-8 byte-order mark is
// skipped. Throws std::invalid_argument naming the file and line.
std::vector<float> read_setpoints_csv(const std::string& path, const std::string& column = "");

// A CSV file written through a temporary file next to it (PATH.partial-PID)
// and renamed to PATH by commit(): a reader never sees half a file, and an
// older file at PATH stays until the new one is whole. Destroyed without
// commit(), the temporary file is removed and PATH is left as it was.
class CsvFile {
public:
    // Creates the temporary file (std::runtime_error if it cannot).
    explicit CsvFile(std::string path);
    ~CsvFile();
    CsvFile(const CsvFile&) = delete;
    CsvFile& operator=(const CsvFile&) = delete;

    const std::string& path() const { return path_; }
    // "# text" lines, before the header.
    void comment(const std::string& text);
    void header(const std::vector<std::string>& names);
    // One row; each value with 9 significant digits (a float round-trips).
    void row(const std::vector<double>& values);
    // Flushes and renames to path() (std::runtime_error on a write error).
    void commit();

private:
    std::string path_, tmp_;
    std::FILE* f_ = nullptr;
};

}  // namespace piezoloop::hostlink
