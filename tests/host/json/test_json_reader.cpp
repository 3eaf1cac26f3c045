// The host's JSON reader (host/json/json_reader): what a hostile text can
// cost is bounded (size, nesting), what JSON allows but a reader would
// resolve silently (duplicate keys) or cannot hold (1e309) is refused with
// the field path, and Field's accessors name the path in every error.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "json/json_reader.hpp"

namespace {

using piezoloop::hostjson::Field;
using piezoloop::hostjson::JsonError;
using piezoloop::hostjson::parse_text;
using piezoloop::hostjson::read_file;

// The message of the JsonError f throws ("" if none).
template <class F>
std::string error_of(F f) {
    try {
        f();
    } catch (const JsonError& e) {
        return e.what();
    }
    return "";
}

TEST(JsonReader, ParsesOrdinaryText) {
    const auto j = parse_text(R"({"a": {"b": [1, 2.5, {"c": true}]}, "d": "x"})", "t");
    EXPECT_EQ(j["a"]["b"][1].get<double>(), 2.5);
    EXPECT_EQ(j["d"], "x");
}

TEST(JsonReader, DuplicateKeysAreRefusedWithTheirPath) {
    EXPECT_EQ(error_of([] { parse_text(R"({"a": 1, "a": 2})", "t"); }), "a: duplicate key");
    EXPECT_EQ(error_of([] { parse_text(R"({"a": [{"x": 1}, {"y": 1, "y": 2}]})", "t"); }), "a[1].y: duplicate key");
    // The same key in different objects is fine.
    EXPECT_NO_THROW(parse_text(R"({"a": {"x": 1}, "b": {"x": 1}})", "t"));
}

TEST(JsonReader, NumbersBeyondADoubleNameTheField) {
    const std::string m = error_of([] { parse_text(R"({"loop": {"rate_Hz": 1e309}})", "t"); });
    EXPECT_EQ(m.rfind("loop.rate_Hz: number out of the range of a double", 0), 0u) << m;
    const std::string a = error_of([] { parse_text(R"({"x": [1, 2, -1e400]})", "t"); });
    EXPECT_EQ(a.rfind("x[2]: number out of the range of a double", 0), 0u) << a;
}

TEST(JsonReader, NestingIsBounded) {
    // 16,000 levels: refused at the limit, without recursion or a crash.
    std::string deep(16000, '[');
    deep += std::string(16000, ']');
    const std::string m = error_of([&] { parse_text(deep, "t"); });
    EXPECT_NE(m.find("nested deeper than 64 levels"), std::string::npos) << m.substr(0, 200);
    std::string ok(64, '[');
    ok += std::string(64, ']');
    EXPECT_NO_THROW(parse_text(ok, "t"));
    const std::string three = error_of([] { parse_text(R"({"a": {"b": {"c": {}}}})", "t", {1 << 20, 3}); });
    EXPECT_EQ(three, "a.b.c: nested deeper than 3 levels");
}

TEST(JsonReader, SizeIsBounded) {
    EXPECT_EQ(error_of([] { parse_text("[1, 2, 3]", "t", {4, 64}); }), "t: longer than 4 bytes");
    // A device that never ends is read only up to the limit.
    EXPECT_EQ(error_of([] { read_file("/dev/zero", {1000, 64}); }), "/dev/zero: larger than 1000 bytes");
    EXPECT_EQ(error_of([] { read_file("/nonexistent/x.json"); }), "/nonexistent/x.json: cannot open");
}

TEST(JsonReader, InvalidTextNamesTheSource) {
    const std::string m = error_of([] { parse_text(R"({"a": 1)", "m.json"); });
    EXPECT_EQ(m.rfind("m.json: not valid JSON: ", 0), 0u) << m;
    EXPECT_EQ(m.find("[json.exception"), std::string::npos) << m;
}

TEST(JsonReader, FieldAccessorsNameThePath) {
    const auto j = parse_text(
        R"({"g": {"n": 3.5, "i": 7, "big": 1e39, "b": true, "e": "sine", "arr": [1, 2, 3], "s": "x"}})", "t");
    const Field g = Field(j, "")["g"];
    EXPECT_EQ(g["n"].number_in(0, 4), 3.5);
    EXPECT_EQ(error_of([&] { (void)g["n"].number_in(0, 1); }), "g.n: must be in [0, 1]");
    EXPECT_EQ(g["i"].integer(0, 10), 7);
    EXPECT_EQ(error_of([&] { (void)g["i"].integer(0, 5); }), "g.i: must be an integer in [0, 5]");
    EXPECT_EQ(error_of([&] { (void)g["n"].integer(0, 5); }), "g.n: must be an integer, not a number");
    EXPECT_EQ(g["big"].number(), 1e39);  // a double holds it
    EXPECT_NE(error_of([&] { (void)g["big"].number_f32(); }).find("g.big: must be within the range of a float"),
              std::string::npos);
    EXPECT_TRUE(g["b"].boolean());
    const char* const waveforms[] = {"triangle", "sine", "square"};
    EXPECT_EQ(g["e"].enumeration(waveforms), 1u);
    EXPECT_EQ(error_of([&] { (void)g["s"].enumeration(waveforms); }),
              "g.s: must be one of triangle|sine|square (got \"x\")");
    EXPECT_EQ(g["arr"].numbers(3).size(), 3u);
    EXPECT_EQ(error_of([&] { (void)g["arr"].numbers(2); }), "g.arr: at most 2 elements (got 3)");
    EXPECT_EQ(error_of([&] { (void)g["missing"]; }), "g.missing: required field is missing");
    EXPECT_FALSE(g.get("missing").has_value());
    EXPECT_EQ(error_of([&] { g.only({"n", "i"}); }).rfind("g.arr: unknown field (allowed here: n, i)", 0), 0u);
}

}  // namespace
