// CSV data files for identification (host/ident/csv_data.hpp): parsing,
// and errors that name the line and the column.
#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>
#include <string>

#include "ident/csv_data.hpp"
#include "test_support.hpp"

using namespace piezoloop::design;
using piezoloop::test::error_of;

namespace {

TEST(IdentCsv, ParsesHeaderCommentsBlankLinesAndCrlf) {
    const CsvData d = parse_csv(
        "# recorded on the bench\r\n"
        "time_s, \"v_V\" ,x_um\r\n"
        "\r\n"
        "0, 1.5, -2e-3\r\n"
        "# a comment in between\n"
        "1e-4,+2,3.25\n",
        "bench.csv");
    ASSERT_EQ(d.names.size(), 3u);
    EXPECT_EQ(d.names[0], "time_s");
    EXPECT_EQ(d.names[1], "v_V");
    EXPECT_EQ(d.names[2], "x_um");
    ASSERT_EQ(d.rows(), 2u);
    EXPECT_EQ(d.lines[0], 4);
    EXPECT_EQ(d.lines[1], 6);
    // Exact: from_chars rounds correctly, as the decimal literals do.
    EXPECT_EQ(d.column("v_V")[0], 1.5);
    EXPECT_EQ(d.column("x_um")[0], -2e-3);
    EXPECT_EQ(d.column("time_s")[1], 1e-4);
    EXPECT_EQ(d.column("v_V")[1], 2.0);
    EXPECT_TRUE(d.has("x_um"));
    EXPECT_FALSE(d.has("y"));
}

TEST(IdentCsv, ErrorsNameTheLineAndColumn) {
    const std::string bad_number = error_of([] { parse_csv("t,u,y\n0,1,2\n1,abc,3\n", "d.csv"); });
    EXPECT_NE(bad_number.find("d.csv:3:"), std::string::npos) << bad_number;
    EXPECT_NE(bad_number.find("column 'u'"), std::string::npos) << bad_number;

    const std::string nan = error_of([] { parse_csv("t,u,y\n0,1,nan\n", "d.csv"); });
    EXPECT_NE(nan.find("d.csv:2:"), std::string::npos) << nan;
    EXPECT_NE(nan.find("column 'y'"), std::string::npos) << nan;
    EXPECT_NE(nan.find("not finite"), std::string::npos) << nan;
    EXPECT_NE(error_of([] { parse_csv("t,u\n0,inf\n"); }).find("column 'u'"), std::string::npos);
    EXPECT_NE(error_of([] { parse_csv("t,u\n0,1e999\n"); }).find("out of the double range"), std::string::npos);

    const std::string fields = error_of([] { parse_csv("t,u,y\n0,1\n", "d.csv"); });
    EXPECT_NE(fields.find("d.csv:2:"), std::string::npos) << fields;
    EXPECT_NE(fields.find("expected 3 fields"), std::string::npos) << fields;

    EXPECT_NE(error_of([] { parse_csv("t,u,y\n0,,1\n"); }).find("column 'u': empty"), std::string::npos);
    EXPECT_NE(error_of([] { parse_csv("0,1,2\n1,2,3\n"); }).find("header"), std::string::npos);
    EXPECT_NE(error_of([] { parse_csv("t,u,t\n0,1,2\n"); }).find("'t' appears twice"), std::string::npos);
    EXPECT_NE(error_of([] { parse_csv("t,,y\n0,1,2\n"); }).find("column 2 has no name"), std::string::npos);
    EXPECT_NE(error_of([] { parse_csv("# nothing\n\n"); }).find("no header"), std::string::npos);
    EXPECT_NE(error_of([] { parse_csv("t,u\n"); }).find("no data rows"), std::string::npos);
    EXPECT_NE(error_of([] { read_csv("/nonexistent/dir/file.csv"); }).find("cannot open"), std::string::npos);
}

TEST(IdentCsv, MissingColumnListsTheColumnsThereAre) {
    const CsvData d = parse_csv("t,v_V,x_um\n0,1,2\n", "loop.csv");
    const std::string e = error_of([&] { d.column("y"); });
    EXPECT_EQ(e.rfind("y: no such column in loop.csv", 0), 0u) << e;
    EXPECT_NE(e.find("t, v_V, x_um"), std::string::npos) << e;
}

TEST(IdentCsv, UniformSamplePeriod) {
    // Time stamps printed to 6 significant digits: jitter well below 1 %.
    const CsvData d = parse_csv("t,u\n0,0\n0.000100001,1\n0.0002,2\n0.000299999,3\n");
    // (t_last - t_first) / (n - 1), exactly as the function defines it.
    EXPECT_DOUBLE_EQ(uniform_sample_period(d, "t"), 0.000299999 / 3);

    const CsvData jump = parse_csv("t,u\n0,0\n1,1\n2,2\n4,3\n", "j.csv");
    const std::string e = error_of([&] { uniform_sample_period(jump, "t"); });
    EXPECT_NE(e.find("j.csv:5:"), std::string::npos) << e;
    EXPECT_NE(e.find("column 't'"), std::string::npos) << e;
    EXPECT_NE(e.find("not uniform"), std::string::npos) << e;

    const CsvData back = parse_csv("t,u\n0,0\n1,1\n1,2\n", "b.csv");
    EXPECT_NE(error_of([&] { uniform_sample_period(back, "t"); }).find("b.csv:4:"), std::string::npos);
    const CsvData one = parse_csv("t,u\n0,0\n");
    EXPECT_NE(error_of([&] { uniform_sample_period(one, "t"); }).find("t: needs at least two"), std::string::npos);
}

TEST(IdentCsv, RequireFiniteNamesTheSample) {
    const double v[] = {1.0, 2.0, std::numeric_limits<double>::quiet_NaN()};
    const std::string e = error_of([&] { require_finite(v, "x_um"); });
    EXPECT_EQ(e, "x_um: sample 2 is not finite (NaN/Inf)");
    EXPECT_EQ(error_of([&] { require_finite(std::span<const double>(v, 2), "x_um"); }), "");
}

TEST(IdentCsv, HeaderlessTableWithChosenFields) {
    // Tab- and space-separated, as a data logger writes; comments skipped.
    const CsvData d = parse_table("# logger\n1.8\t0\t-123.0\n  1.9 0  -120.5\n\n2.0,0,-118\n",
                                  parse_column_picks("u=1, y=3"), "run.dat");
    ASSERT_EQ(d.rows(), 3u);
    EXPECT_EQ(d.names, (std::vector<std::string>{"u", "y"}));
    EXPECT_EQ(d.column("u"), (std::vector<double>{1.8, 1.9, 2.0}));
    EXPECT_EQ(d.column("y"), (std::vector<double>{-123.0, -120.5, -118.0}));
    EXPECT_EQ(d.lines, (std::vector<int>{2, 3, 5}));
    const auto picks = parse_column_picks("u=1,y=5");
    EXPECT_EQ(error_of([&] { parse_table("1 2 3\n", picks, "run.dat"); }),
              "run.dat:1: column 'y' (field 5): the line has only 3 fields");
    EXPECT_EQ(error_of([&] { parse_table("1 2 3 4 5\n1 2 3 4 nan\n", picks, "run.dat"); }),
              "run.dat:2: column 'y' (field 5): 'nan' is not finite (NaN/Inf)");
    EXPECT_EQ(error_of([&] { parse_table("1 2 3 4 x\n", picks, "run.dat"); }),
              "run.dat:1: column 'y' (field 5): 'x' is not a number");
    EXPECT_EQ(error_of([&] { parse_table("# only\n", picks, "run.dat"); }), "run.dat: no data rows");
    // The same file read as CSV says what it looks like.
    EXPECT_EQ(error_of([] { parse_csv("1.8\t0\t-123\n", "run.dat"); }).rfind("run.dat:1: header: no comma-separated", 0), 0u);
    EXPECT_EQ(error_of([&] { parse_column_picks("u=0,y=5"); }).rfind("columns: 'u=0': FIELD must be", 0), 0u);
    EXPECT_EQ(error_of([&] { parse_column_picks("u1"); }).rfind("columns: 'u1': expected NAME=FIELD", 0), 0u);
    EXPECT_EQ(error_of([&] { parse_column_picks("u=1,u=2"); }), "columns: 'u=2': column 'u' named twice");
}

}  // namespace
