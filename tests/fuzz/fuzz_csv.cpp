// libFuzzer target: arbitrary bytes as a CSV data file (`identify --data F`)
// through the CSV reader, then the sample period of its first column as
// `identify rls` derives it, and as a headerless table (`--columns u=1,y=5`).
// Refusing the input with std::invalid_argument
// (file, line and what is wrong) is the expected outcome; a crash, a
// sanitizer finding, any other exception, or a timeout is a defect.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "ident/csv_data.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    try {
        const piezoloop::design::CsvData csv = piezoloop::design::parse_csv(text, "fuzz.csv");
        if (!csv.names.empty()) (void)piezoloop::design::uniform_sample_period(csv, csv.names.front());
    } catch (const std::invalid_argument&) {
    }
    try {
        static const auto picks = piezoloop::design::parse_column_picks("u=1,y=5");
        (void)piezoloop::design::parse_table(text, picks, "fuzz.dat");
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
