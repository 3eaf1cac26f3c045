// The console's step and loops forms (host/ui/step_loops_job): their fields,
// the CLI's refusals (measure/step_loops_plan) at the forms' field names, the
// CSV of a result as the CLI writes it; and the console's measurement job
// (host/ui/measurement_job): progress, result, refusal, stop.
#include <gtest/gtest.h>

#include <chrono>
#include <sstream>
#include <thread>

#include "ui/step_loops_job.hpp"

namespace piezoloop::ui {
namespace {

using nlohmann::json;

measure::MeasureBounds bounds() {
    measure::MeasureBounds b;
    b.rate_Hz = 10000.0;
    b.limits.u_min_V = 0.0f;
    b.limits.u_max_V = 10.0f;
    b.closed_range = {-20.0, 20.0};
    b.whose = "board's";
    return b;
}

TEST(UiStepForm, TheFieldsBecomeTheCliRequest) {
    const StepForm f = parse_step_form(
        {{"mode", "open"}, {"step_V", 1.5}, {"bias_V", 3}, {"duration_s", 0.05}, {"restart_stage", true}});
    EXPECT_EQ(f.input.mode, "open");
    EXPECT_EQ(*f.input.step_V, 1.5);
    EXPECT_EQ(*f.input.bias_V, 3.0);
    EXPECT_FALSE(f.input.step_um.has_value());
    EXPECT_EQ(f.input.duration_s, 0.05);
    EXPECT_TRUE(f.restart_stage);
    const measure::StepRequest r = measure::step_request(f.input, bounds(), std::nullopt);
    EXPECT_FALSE(r.closed);
    EXPECT_EQ(r.step, 1.5);
    EXPECT_EQ(r.from, 3.0);
    // A closed step without from_um starts where the board holds (null: not given).
    const StepForm c = parse_step_form({{"mode", "closed"}, {"step_um", 2}, {"from_um", nullptr}});
    EXPECT_FALSE(c.input.from_um.has_value());
    EXPECT_EQ(measure::step_request(c.input, bounds(), 4.25).from, 4.25);
}

std::string step_field(const json& j) {
    try {
        const StepForm f = parse_step_form(j);
        const measure::MeasureBounds b = bounds();
        (void)measure::plan_step(b, measure::step_request(f.input, b, 0.0));
    } catch (const FieldRefusal& e) {
        return e.field;
    } catch (const std::invalid_argument& e) {
        return step_refusal(e.what()).field;
    }
    return "(accepted)";
}

TEST(UiStepForm, RefusalsAreAtTheirField) {
    EXPECT_EQ(step_field({{"mode", "open"}, {"step_V", 1}, {"bias_V", 3}}), "(accepted)");
    // 3 V + 8 V passes the 10 V command limit: the plan's message, at step_V.
    EXPECT_EQ(step_field({{"mode", "open"}, {"step_V", 8}, {"bias_V", 3}}), "step_V");
    EXPECT_EQ(step_field({{"mode", "open"}, {"step_V", 1}, {"bias_V", -1}}), "bias_V");
    EXPECT_EQ(step_field({{"mode", "open"}, {"step_V", 1}, {"duration_s", 0}}), "duration_s");
    EXPECT_EQ(step_field({{"mode", "closed"}, {"step_um", 50}}), "step_um");
    EXPECT_EQ(step_field({{"mode", "closed"}, {"step_um", 1}, {"from_um", 30}}), "from_um");
    EXPECT_EQ(step_field({{"mode", "closed"}, {"step_V", 1}}), "step_V");  // closed steps the reference
    EXPECT_EQ(step_field({{"mode", "half"}, {"step_V", 1}}), "mode");
    EXPECT_EQ(step_field({{"mode", "open"}, {"step_V", "one"}}), "step_V");
    EXPECT_EQ(step_field({{"mode", "open"}, {"step_V", 1}, {"colour", 1}}), "");
    const FieldRefusal m = step_refusal("--step-v: from 3 V the step must end within [0, 10] V: between -3 and 7 V");
    EXPECT_EQ(m.field, "step_V");
    EXPECT_STREQ(m.what(), "step_V: from 3 V the step must end within [0, 10] V: between -3 and 7 V");
}

std::string loops_field(const json& j) {
    try {
        const LoopsForm f = parse_loops_form(j);
        const measure::MeasureBounds b = bounds();
        (void)measure::plan_loops(b, measure::loops_request(f.amplitudes_V, f.bias_V, f.frequency_Hz, f.cycles, f.shape, b));
    } catch (const FieldRefusal& e) {
        return e.field;
    } catch (const std::invalid_argument& e) {
        return loops_refusal(e.what()).field;
    }
    return "(accepted)";
}

TEST(UiLoopsForm, TheFieldsAndTheirRefusals) {
    const LoopsForm f = parse_loops_form({{"amplitudes_V", {2, 4}}, {"bias_V", nullptr}, {"frequency_Hz", 20},
                                          {"cycles", 3}, {"shape", "sine"}, {"restart_stage", true}});
    EXPECT_EQ(f.amplitudes_V, (std::vector<double>{2, 4}));
    EXPECT_FALSE(f.bias_V.has_value());
    EXPECT_EQ(f.frequency_Hz, 20.0);
    EXPECT_EQ(f.cycles, 3);
    EXPECT_EQ(f.shape, "sine");
    EXPECT_TRUE(f.restart_stage);
    const json ok = {{"amplitudes_V", {2, 4}}, {"frequency_Hz", 20}, {"cycles", 2}};
    auto with = [&](const char* k, const json& v) {
        json j = ok;
        j[k] = v;
        return j;
    };
    EXPECT_EQ(loops_field(ok), "(accepted)");
    EXPECT_EQ(loops_field(with("amplitudes_V", {2, 12})), "amplitudes_V");  // above the 10 V limit
    EXPECT_EQ(loops_field(with("amplitudes_V", "2,4")), "amplitudes_V");
    EXPECT_EQ(loops_field(with("bias_V", 11)), "bias_V");
    EXPECT_EQ(loops_field(with("frequency_Hz", 600)), "frequency_Hz");  // above rate / 20
    EXPECT_EQ(loops_field(with("frequency_Hz", 0.001)), "frequency_Hz");  // too long a recording
    EXPECT_EQ(loops_field(with("cycles", 1.5)), "cycles");
    EXPECT_EQ(loops_field(with("cycles", 0)), "cycles");
    EXPECT_EQ(loops_field(with("shape", "square")), "shape");
    EXPECT_EQ(loops_field({{"frequency_Hz", 20}}), "amplitudes_V");
}

// A result's CSV is the CLI's: the JSON's arrays written by the CLI's writer
// give the text the writer gives the run itself.
TEST(UiStepLoopsCsv, TheResultsCsvIsTheClis) {
    measure::StepRun s;
    s.time_s = {-0.0002, -0.0001, 0.0, 0.0001};
    s.r_um = {0.0, 0.0, 0.0, 0.0};
    s.u_V = {3.0, 3.0, 4.0, 4.0};
    s.y_um = {1.0, 1.0000001, 1.25, 1.5};
    const json report = measure::step_report(measure::StepRequest{}, s, json::object());
    std::ostringstream direct;
    measure::write_step_csv(direct, s);
    EXPECT_EQ(step_csv(json::parse(report.dump())), direct.str());
    EXPECT_EQ(direct.str().substr(0, 8), "t,r,u,y\n");
    measure::LoopsRun l;
    l.time_s = {0.0, 0.1};
    l.u_V = {0.5, 0.75};
    l.y_um = {0.1, 0.2};
    l.amplitude_V = {2.0, 2.0};
    const json lj = {{"time_s", l.time_s}, {"u_V", l.u_V}, {"y_um", l.y_um}, {"amplitude_V", l.amplitude_V}};
    std::ostringstream ldirect;
    measure::write_loops_csv(ldirect, l);
    EXPECT_EQ(loops_csv(json::parse(lj.dump())), ldirect.str());
    EXPECT_EQ(step_csv(json()), "");
}

json wait_done(const MeasurementJob& job) {
    for (int i = 0; i < 500 && job.running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return job.progress_json();
}

TEST(UiMeasurementJob, ProgressResultRefusalAndStop) {
    MeasurementJob job("a test");
    EXPECT_EQ(job.progress_json()["state"], "idle");
    EXPECT_TRUE(job.result_json().is_null());
    std::atomic<bool> go{false};
    std::vector<json> seen;
    job.start({{"n", 1}}, [&](const MeasurementJob::Context& c) {
        c.note("a decision");
        c.report("recording", 0.5);
        while (!go) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        return json{{"answer", 42}};
    });
    for (int i = 0; i < 500 && job.progress_json()["phase"] != "recording"; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    EXPECT_EQ(job.progress_json()["phase"], "recording");
    EXPECT_EQ(job.progress_json()["fraction"], 0.5);
    EXPECT_EQ(job.progress_json()["request"], (json{{"n", 1}}));
    EXPECT_EQ(job.progress_json()["log"], (json{"a decision"}));
    EXPECT_THROW(job.start(json::object(), [](auto&) { return json(); }), BoardBusy);
    const uint64_t before = job.result_serial();
    go = true;
    EXPECT_EQ(wait_done(job)["state"], "done");
    EXPECT_EQ(job.result_json()["answer"], 42);
    EXPECT_GT(job.result_serial(), before);

    job.start(json::object(), [](auto&) -> json { throw FieldRefusal("step_V", "step_V: too large"); });
    const json refused = wait_done(job);
    EXPECT_EQ(refused["state"], "failed");
    EXPECT_EQ(refused["error"]["field"], "step_V");
    EXPECT_EQ(job.result_json()["answer"], 42);  // the last result stays

    job.start(json::object(), [](const MeasurementJob::Context& c) -> json {
        while (!c.stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        throw std::runtime_error("interrupted");
    });
    job.request_stop();
    const json stopped = wait_done(job);
    EXPECT_EQ(stopped["state"], "stopped");
    EXPECT_FALSE(stopped.contains("error") && stopped["error"]["field"] != "");
}

}  // namespace
}  // namespace piezoloop::ui
