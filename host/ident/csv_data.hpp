// Measured data for identification: CSV files with a header row naming the
// columns (e.g. `t,u,y` or `time_s,v_V,x_um`), one sample per row.
//
// Accepted: comma separated fields, optional surrounding spaces and double
// quotes around header names, blank lines and lines starting with '#'
// (comments) anywhere, CRLF line ends. Every data row must have as many
// fields as the header and every field must be a finite number. Errors throw
// std::invalid_argument with "<source>:<line>: column '<name>': <what>".
#pragma once

#include <cstddef>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace piezoloop::design {

struct CsvData {
    std::string source;                       // file name (or a label) used in messages
    std::vector<std::string> names;           // column names, in file order
    std::vector<std::vector<double>> columns; // columns[c][row]
    std::vector<int> lines;                   // 1-based file line of each row

    std::size_t rows() const { return lines.size(); }
    bool has(std::string_view name) const;
    // The named column; throws naming it and listing the columns there are.
    const std::vector<double>& column(std::string_view name) const;
};

// Called now and then during a long read ("reading: 3.1 M lines, 31 %").
using CsvProgress = std::function<void(const std::string&)>;

// Parses CSV text; `source` names it in error messages.
CsvData parse_csv(std::string_view text, const std::string& source = "<data>", const CsvProgress& progress = {});
// Reads and parses a file; an unreadable file throws naming the path.
CsvData read_csv(const std::string& path, const CsvProgress& progress = {});

// Headerless numeric tables (a data logger's .dat file): fields separated
// by tabs, spaces or commas (runs of blanks count once), '#' comment lines
// and blank lines skipped. `picks` names the 1-based fields to keep, e.g.
// "u=1,y=5" (parse_column_picks); the result holds those columns under
// those names. Errors name the file, line and column as parse_csv's do.
struct ColumnPick {
    std::string name;
    int field = 0;  // 1-based
};
// Parses "name=field,name=field,..."; throws naming `option` on bad syntax,
// a field < 1, or a name given twice.
std::vector<ColumnPick> parse_column_picks(std::string_view spec, const std::string& option = "columns");
CsvData parse_table(std::string_view text, const std::vector<ColumnPick>& picks,
                    const std::string& source = "<data>", const CsvProgress& progress = {});
CsvData read_table(const std::string& path, const std::vector<ColumnPick>& picks, const CsvProgress& progress = {});

// Sample period of a time column: strictly increasing, every step within
// `rel_jitter` of the median step (default 1 %: time stamps printed with six
// significant digits jitter by up to ~0.5 % of a period); returns the mean
// step. Throws naming the column and the line of the first offending row.
double uniform_sample_period(const CsvData& data, std::string_view time_column,
                             double rel_jitter = 1e-2);

// Throws std::invalid_argument("<name>: ...") if any value is NaN or Inf
// (identification entry points call it on their inputs).
void require_finite(std::span<const double> values, std::string_view name);

}  // namespace piezoloop::design
