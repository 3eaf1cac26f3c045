// host/lti/model_json: the three model forms, ts, series, writing back,
// and that every malformed model names the offending field.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "lti/freqresp.hpp"
#include "lti/lti_convert.hpp"
#include "lti/model_json.hpp"

using namespace piezoloop::design;
using nlohmann::json;

namespace {

std::string error_of(const std::string& text) {
    try {
        parse_model(json::parse(text));
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "no error";
}

}  // namespace

TEST(DesignModelJson, ThreeFormsGiveTheSameModel) {
    // (s + 2) / ((s + 1)(s^2 + 2 s + 5)) written three ways.
    const Zpk a = parse_model(json::parse(R"({"num": [1, 2], "den": [1, 3, 7, 5]})"));
    const Zpk b = parse_model(json::parse(R"({"zeros": [-2], "poles": [[-1, 0], [-1, 2], [-1, -2]], "gain": 1})"));
    const Zpk c = parse_model(json::parse(
        R"({"series": [{"num": [1, 2], "den": [1, 1]}, {"zeros": [], "poles": [[-1, 2], [-1, -2]], "gain": 1}]})"));
    for (const cplx s : {cplx(0.0, 0.5), cplx(0.0, 3.0), cplx(0.2, 30.0)}) {
        const cplx want = (s + 2.0) / ((s + 1.0) * (s * s + 2.0 * s + 5.0));
        // Roots of a cubic / exact roots, factored evaluation: 1e-14.
        EXPECT_NEAR(std::abs(evaluate(a, s) - want), 0.0, 1e-14 * std::abs(want));
        EXPECT_NEAR(std::abs(evaluate(b, s) - want), 0.0, 1e-15 * std::abs(want));
        EXPECT_NEAR(std::abs(evaluate(c, s) - want), 0.0, 1e-15 * std::abs(want));
    }
    EXPECT_EQ(a.ts, 0.0);
}

TEST(DesignModelJson, TsAndSeriesInheritance) {
    const Zpk d = parse_model(json::parse(R"({"num": [0.3558], "den": [1, -0.6442], "ts": 1e-5})"));
    EXPECT_EQ(d.ts, 1e-5);
    // Members without ts inherit the series' ts.
    const Zpk s = parse_model(
        json::parse(R"({"ts": 1e-3, "series": [{"num": [1], "den": [1, -0.5]}, {"num": [1, 0], "den": [1, 0.2]}]})"));
    EXPECT_EQ(s.ts, 1e-3);
    EXPECT_EQ(s.poles.size(), 2u);
    // Members that all name the same ts are fine without a series ts.
    const Zpk m = parse_model(json::parse(
        R"({"series": [{"num": [1], "den": [1, -0.5], "ts": 1e-3}, {"num": [1], "den": [1, 0.2], "ts": 1e-3}]})"));
    EXPECT_EQ(m.ts, 1e-3);
    // Documentation keys are ignored.
    EXPECT_NO_THROW(parse_model(json::parse(
        R"({"name": "x", "description": "y", "source": "z", "comment": "c", "units": "V", "_note": 1,
            "num": [1], "den": [1, 1]})")));
}

TEST(DesignModelJson, WritesBackAndReadsTheSame) {
    const Zpk z = parse_model(json::parse(
        R"({"series": [{"zeros": [1.22e5, -2.99e4], "poles": [], "gain": -20.7}, {"num": [1], "den": [1, 925, 4.59e5]},
                       {"num": [1], "den": [1, 55, 1.4e7]}]})"));
    const json j = to_json(z);
    const Zpk back = parse_model(j);
    EXPECT_EQ(back.zeros, z.zeros);  // doubles written and read exactly
    EXPECT_EQ(back.poles, z.poles);
    EXPECT_EQ(back.gain, z.gain);
    const Tf t{{1.0, 2.0}, {1.0, -0.5}, 1e-3};
    const json jt = to_json(t);
    EXPECT_EQ(jt["num"], json::parse("[1.0, 2.0]"));
    EXPECT_EQ(jt["ts"], 1e-3);
}

TEST(DesignModelJson, ErrorsNameTheField) {
    struct Case {
        const char* text;
        const char* field;   // must appear in the message
        const char* reason;  // and this
    };
    const Case cases[] = {
        {R"({"num": [1], "den": [0, 1]})", "model.den[0]", "leading coefficient must be non-zero"},
        {R"({"num": [1, 2, 3], "den": [1, 1]})", "model", "improper"},
        {R"({"num": [1], "den": []})", "model.den", "must not be empty"},
        {R"({"num": [], "den": [1]})", "model.num", "must not be empty"},
        {R"({"num": [1, "x"], "den": [1, 1]})", "model.num[1]", "must be a number"},
        {R"({"num": [1]})", "model", "no den"},
        {R"({"num": [1], "den": [1, 1], "zeros": []})", "model", "exactly one of"},
        {R"({"num": [1], "den": [1, 1], "ts": 0})", "model.ts", "must be > 0"},
        {R"({"num": [1], "den": [1, 1], "ts": -1e-3})", "model.ts", "must be > 0"},
        {R"({"num": [1], "den": [1, 1], "tss": 1})", "model.tss", "unknown field"},
        {R"({"zeros": [], "poles": [[-1, 2]], "gain": 1})", "model.poles[0]", "conjugate"},
        {R"({"zeros": [], "poles": [[-1, 2, 3]], "gain": 1})", "model.poles[0]", "[re, im]"},
        {R"({"zeros": [], "poles": [-1]})", "model", "gain"},
        {R"({"zeros": [], "poles": [-1], "gain": "2"})", "model.gain", "must be a number"},
        {R"({"series": []})", "model.series", "must not be empty"},
        {R"({"series": {"num": [1]}})", "model.series", "array"},
        {R"({"series": [{"num": [1], "den": [1, 1]}, {"num": [1], "den": [0, 1]}]})", "model.series[1].den[0]",
         "leading coefficient must be non-zero"},
        {R"({"series": [{"num": [1], "den": [1, 1], "ts": 1e-3}, {"num": [1], "den": [1, 2]}]})",
         "model.series[1].ts", "mixed ts"},
        {R"({"ts": 1e-3, "series": [{"num": [1], "den": [1, 1], "ts": 1e-4}]})", "model.series[0].ts", "mixed ts"},
        {R"({"series": [{"series": [{"num": [1], "den": [1, 1]}, {"zeros": [[1, 1]], "poles": [], "gain": 1}]}]})",
         "model.series[0].series[1].zeros[0]", "conjugate"},
        {R"([1, 2])", "model", "must be an object"},
    };
    for (const Case& c : cases) {
        const std::string msg = error_of(c.text);
        EXPECT_NE(msg.find(c.field), std::string::npos) << c.text << " -> " << msg;
        EXPECT_NE(msg.find(c.reason), std::string::npos) << c.text << " -> " << msg;
    }
    // NaN / inf cannot be written in JSON text but can reach parse_model
    // from code.
    try {
        parse_model(json{{"num", {1.0}}, {"den", {1.0, NAN}}});
        ADD_FAILURE() << "no error";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("model.den[1]: must be finite"), std::string::npos) << e.what();
    }
    // A series may hold improper members as long as the whole is proper.
    EXPECT_NO_THROW(parse_model(json::parse(
        R"({"series": [{"num": [1, 1, 1], "den": [1]}, {"num": [1], "den": [1, 3, 3]}]})")));
}

TEST(DesignModelJson, FileErrorsNameTheFile) {
    const std::string path = ::testing::TempDir() + "design_model_json_bad.json";
    {
        std::ofstream f(path);
        f << R"({"num": [1], "den": [0, 1]})";
    }
    try {
        load_model_file(path);
        FAIL() << "no error";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find(path + ": model.den[0]"), std::string::npos) << e.what();
    }
    {
        std::ofstream f(path);
        f << R"({"num": [1], "den": [1, 1)";
    }
    try {
        load_model_file(path);
        FAIL() << "no error";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("not valid JSON"), std::string::npos) << e.what();
    }
    {
        std::ofstream f(path);
        f << R"({"num": [1], "den": [1, 1e999]})";  // out of double range
    }
    try {
        load_model_file(path);
        FAIL() << "no error";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("not valid JSON"), std::string::npos) << e.what();
    }
    std::remove(path.c_str());
    EXPECT_THROW(load_model_file(path), std::invalid_argument);  // missing file
}
