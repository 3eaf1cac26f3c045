#include "ident/csv_data.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace piezoloop::design {
namespace {

std::string_view trim(std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
    return s;
}

std::vector<std::string_view> split(std::string_view line) {
    std::vector<std::string_view> out;
    std::size_t start = 0;
    for (;;) {
        const std::size_t comma = line.find(',', start);
        out.push_back(trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos
                                                                              : comma - start)));
        if (comma == std::string_view::npos) break;
        start = comma + 1;
    }
    return out;
}

[[noreturn]] void fail(const std::string& source, int line, const std::string& what) {
    throw std::invalid_argument(source + ":" + std::to_string(line) + ": " + what);
}

std::string in_quotes(std::string_view s) { return "'" + std::string(s) + "'"; }

}  // namespace

bool CsvData::has(std::string_view name) const {
    for (const auto& n : names)
        if (n == name) return true;
    return false;
}

const std::vector<double>& CsvData::column(std::string_view name) const {
    for (std::size_t c = 0; c < names.size(); ++c)
        if (names[c] == name) return columns[c];
    std::string have;
    for (const auto& n : names) have += (have.empty() ? "" : ", ") + n;
    throw std::invalid_argument(std::string(name) + ": no such column in " + source +
                                " (columns: " + have + ")");
}

namespace {

// The next line of text from pos that is neither empty nor a comment,
// trimmed, into line (line_no counts every line read); progress every Mi
// lines. False at the end of the text.
bool next_data_line(std::string_view text, std::size_t& pos, int& line_no, const CsvProgress& progress,
                    std::string_view& line) {
    while (pos <= text.size()) {
        const std::size_t nl = text.find('\n', pos);
        const std::string_view raw =
            text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
        pos = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
        ++line_no;
        if (progress && (line_no & 0xFFFFF) == 0)
            progress("reading: " + std::to_string(line_no >> 20) + " Mi lines, " +
                     std::to_string(100 * std::min(pos, text.size()) / std::max<std::size_t>(text.size(), 1)) + " %");
        line = trim(raw);
        if (!line.empty() && line.front() != '#') return true;
    }
    return false;
}

}  // namespace

CsvData parse_csv(std::string_view text, const std::string& source, const CsvProgress& progress) {
    CsvData d;
    d.source = source;
    // A UTF-8 byte-order mark (spreadsheets write one) is not part of the
    // first column's name.
    if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
    int line_no = 0;
    bool have_header = false;
    std::size_t pos = 0;
    std::string_view line;
    while (next_data_line(text, pos, line_no, progress, line)) {
        const auto fields = split(line);
        if (!have_header) {
            const bool numeric_start = std::string_view("0123456789+-.").find(line.front()) != std::string_view::npos;
            if (fields.size() == 1 && (line.find('\t') != std::string_view::npos ||
                                       (numeric_start && line.find(' ') != std::string_view::npos)))
                fail(source, line_no,
                     "header: no comma-separated column names (fields separated by blanks or tabs: a headerless "
                     "table? `identify` reads one with --columns NAME=FIELD,..., e.g. u=1,y=5)");
            for (std::size_t c = 0; c < fields.size(); ++c) {
                std::string_view name = fields[c];
                if (name.size() >= 2 && name.front() == '"' && name.back() == '"')
                    name = trim(name.substr(1, name.size() - 2));
                if (name.empty())
                    fail(source, line_no, "header: column " + std::to_string(c + 1) + " has no name");
                double probe;
                const auto r = std::from_chars(name.data(), name.data() + name.size(), probe);
                if (r.ec == std::errc() && r.ptr == name.data() + name.size())
                    fail(source, line_no,
                         "header: column " + std::to_string(c + 1) + " is the number " + in_quotes(name) +
                             "; the first row must name the columns (e.g. t,u,y)");
                for (const auto& n : d.names)
                    if (n == name) fail(source, line_no, "header: column " + in_quotes(name) + " appears twice");
                d.names.emplace_back(name);
            }
            d.columns.resize(d.names.size());
            have_header = true;
            continue;
        }
        if (fields.size() != d.names.size())
            fail(source, line_no,
                 "expected " + std::to_string(d.names.size()) + " fields (one per header column), got " +
                     std::to_string(fields.size()));
        for (std::size_t c = 0; c < fields.size(); ++c) {
            const std::string_view f = fields[c];
            const std::string col = "column " + in_quotes(d.names[c]) + ": ";
            if (f.empty()) fail(source, line_no, col + "empty field");
            // from_chars does not accept a leading '+'; allow it as people write it.
            const char* first = f.data() + (f.front() == '+' ? 1 : 0);
            double v = 0.0;
            const auto r = std::from_chars(first, f.data() + f.size(), v);
            if (r.ec == std::errc::result_out_of_range)
                fail(source, line_no, col + in_quotes(f) + " is out of the double range");
            if (r.ec != std::errc() || r.ptr != f.data() + f.size())
                fail(source, line_no, col + in_quotes(f) + " is not a number");
            if (!std::isfinite(v)) fail(source, line_no, col + in_quotes(f) + " is not finite (NaN/Inf)");
            d.columns[c].push_back(v);
        }
        d.lines.push_back(line_no);
    }
    if (!have_header) throw std::invalid_argument(source + ": empty: no header row naming the columns");
    if (d.lines.empty()) throw std::invalid_argument(source + ": no data rows after the header");
    return d;
}

namespace {

std::string read_text(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) throw std::invalid_argument(path + ": cannot open file");
    // Read in place (one copy of the file in memory, not two through a
    // stringstream).
    std::string text;
    char buf[1 << 16];
    while (f.read(buf, sizeof buf) || f.gcount() > 0) text.append(buf, static_cast<std::size_t>(f.gcount()));
    return text;
}

// A finite number or a message saying what the field is instead.
std::string parse_number(std::string_view f, double& v) {
    if (f.empty()) return "empty field";
    // from_chars does not accept a leading '+'; allow it as people write it.
    const char* first = f.data() + (f.front() == '+' ? 1 : 0);
    const auto r = std::from_chars(first, f.data() + f.size(), v);
    if (r.ec == std::errc::result_out_of_range) return in_quotes(f) + " is out of the double range";
    if (r.ec != std::errc() || r.ptr != f.data() + f.size()) return in_quotes(f) + " is not a number";
    if (!std::isfinite(v)) return in_quotes(f) + " is not finite (NaN/Inf)";
    return {};
}

}  // namespace

CsvData read_csv(const std::string& path, const CsvProgress& progress) {
    return parse_csv(read_text(path), path, progress);
}

std::vector<ColumnPick> parse_column_picks(std::string_view spec, const std::string& option) {
    std::vector<ColumnPick> picks;
    std::size_t start = 0;
    for (;;) {
        const std::size_t comma = spec.find(',', start);
        const std::string_view item =
            trim(spec.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
        const std::size_t eq = item.find('=');
        const std::string bad = option + ": " + in_quotes(item) + ": ";
        if (eq == std::string_view::npos || eq == 0)
            throw std::invalid_argument(bad + "expected NAME=FIELD (e.g. u=1,y=5; fields count from 1)");
        const std::string_view name = trim(item.substr(0, eq)), field = trim(item.substr(eq + 1));
        int f = 0;
        const auto r = std::from_chars(field.data(), field.data() + field.size(), f);
        if (r.ec != std::errc() || r.ptr != field.data() + field.size() || f < 1 || f > 1000)
            throw std::invalid_argument(bad + "FIELD must be a whole number in [1, 1000] (fields count from 1)");
        for (const auto& p : picks)
            if (p.name == name) throw std::invalid_argument(bad + "column " + in_quotes(name) + " named twice");
        picks.push_back({std::string(name), f});
        if (comma == std::string_view::npos) break;
        start = comma + 1;
    }
    return picks;
}

CsvData parse_table(std::string_view text, const std::vector<ColumnPick>& picks, const std::string& source,
                    const CsvProgress& progress) {
    if (picks.empty()) throw std::invalid_argument("columns: none chosen");
    CsvData d;
    d.source = source;
    for (const auto& p : picks) d.names.push_back(p.name);
    d.columns.resize(picks.size());
    int line_no = 0;
    std::size_t pos = 0;
    std::string_view line;
    std::vector<std::string_view> fields;
    while (next_data_line(text, pos, line_no, progress, line)) {
        fields.clear();
        std::size_t i = 0;
        while (i < line.size()) {
            while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == ',')) ++i;
            const std::size_t b = i;
            while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != ',') ++i;
            if (i > b) fields.push_back(line.substr(b, i - b));
        }
        for (std::size_t c = 0; c < picks.size(); ++c) {
            const std::string col = "column " + in_quotes(picks[c].name) + " (field " +
                                    std::to_string(picks[c].field) + "): ";
            if (static_cast<std::size_t>(picks[c].field) > fields.size())
                fail(source, line_no, col + "the line has only " + std::to_string(fields.size()) + " fields");
            double v = 0.0;
            if (const std::string why = parse_number(fields[static_cast<std::size_t>(picks[c].field - 1)], v);
                !why.empty())
                fail(source, line_no, col + why);
            d.columns[c].push_back(v);
        }
        d.lines.push_back(line_no);
    }
    if (d.lines.empty()) throw std::invalid_argument(source + ": no data rows");
    return d;
}

CsvData read_table(const std::string& path, const std::vector<ColumnPick>& picks, const CsvProgress& progress) {
    return parse_table(read_text(path), picks, path, progress);
}

double uniform_sample_period(const CsvData& data, std::string_view time_column, double rel_jitter) {
    const std::vector<double>& t = data.column(time_column);
    const std::string name(time_column);
    if (t.size() < 2)
        throw std::invalid_argument(name + ": needs at least two samples to give a sample period");
    for (std::size_t k = 1; k < t.size(); ++k)
        if (!(t[k] > t[k - 1]))
            fail(data.source, data.lines[k], "column " + in_quotes(name) + ": time must increase strictly");
    // Jitter is judged against the median step (one gap or duplicate row
    // does not shift it), the period returned is the mean over the file.
    std::vector<double> dts;
    for (std::size_t k = 1; k < t.size(); ++k) dts.push_back(t[k] - t[k - 1]);
    std::nth_element(dts.begin(), dts.begin() + static_cast<std::ptrdiff_t>(dts.size() / 2), dts.end());
    const double median = dts[dts.size() / 2];
    for (std::size_t k = 1; k < t.size(); ++k) {
        const double dt = t[k] - t[k - 1];
        if (std::fabs(dt - median) > rel_jitter * median) {
            std::ostringstream m;
            m << "column '" << name << "': sampling is not uniform (step " << dt << " s vs median " << median
              << " s); identification needs a constant sample period";
            fail(data.source, data.lines[k], m.str());
        }
    }
    const double ts = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
    return ts;
}

void require_finite(std::span<const double> values, std::string_view name) {
    for (std::size_t k = 0; k < values.size(); ++k)
        if (!std::isfinite(values[k]))
            throw std::invalid_argument(std::string(name) + ": sample " + std::to_string(k) +
                                        " is not finite (NaN/Inf)");
}

}  // namespace piezoloop::design
