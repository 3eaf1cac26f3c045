#include "ui/measurement_job.hpp"

#include <chrono>

#include "link/client.hpp"
#include "ui/board_session.hpp"
#include "ui/field_refusal.hpp"

namespace piezoloop::ui {

using nlohmann::json;

MeasurementJob::~MeasurementJob() { shutdown(); }

void MeasurementJob::shutdown() {
    stop_ = true;
    if (worker_.joinable()) worker_.join();
}

json MeasurementJob::start(const json& request, Work work) {
    const std::lock_guard lock(start_m_);  // one start at a time (a double click)
    if (running_) throw BoardBusy(what_ + " is running: stop it first");
    if (worker_.joinable()) worker_.join();
    running_ = true;
    stop_ = false;
    {
        const std::lock_guard l(m_);
        progress_["request"] = request;
        progress_["log"] = json::array();
        progress_.erase("error");
    }
    set_progress("running", "starting", 0.0);
    worker_ = std::thread([this, work = std::move(work)] { run(work); });
    return progress_json();
}

void MeasurementJob::set_progress(const std::string& state, const std::string& phase, double fraction) {
    {
        const std::lock_guard lock(m_);
        progress_["state"] = state;
        progress_["phase"] = phase;
        progress_["fraction"] = fraction;
    }
    ++progress_serial_;
}

void MeasurementJob::fail(const std::string& state, const std::string& field, const std::string& message) {
    {
        const std::lock_guard lock(m_);
        progress_["error"] = {{"field", field}, {"message", message}};
    }
    set_progress(state, "", 0.0);
}

void MeasurementJob::run(Work work) {
    auto last = std::chrono::steady_clock::now() - std::chrono::seconds(1);
    std::string last_phase;
    Context context;
    context.report = [&](const std::string& phase, double fraction) {
        // At most ten reports a second within a phase; every new phase.
        const auto now = std::chrono::steady_clock::now();
        if (phase == last_phase && fraction < 1.0 && now - last < std::chrono::milliseconds(100)) return;
        last = now;
        last_phase = phase;
        set_progress("running", phase, fraction);
    };
    context.note = [this](const std::string& line) {
        {
            const std::lock_guard lock(m_);
            progress_["log"].push_back(line);
        }
        ++progress_serial_;
    };
    context.stop_requested = [this] { return stop_.load(); };
    try {
        json result = work(context);
        {
            const std::lock_guard lock(m_);
            result_ = std::move(result);
        }
        ++result_serial_;
        set_progress("done", "", 1.0);
    } catch (const FieldRefusal& e) {
        fail("failed", e.field, e.what());
    } catch (const hostlink::DeviceError& e) {
        fail("failed", "", std::string("the board refused: ") + e.what());
    } catch (const std::exception& e) {
        if (stop_) fail("stopped", "", "stopped before the end (on a board: its groups put back, the loop left disarmed)");
        else fail("failed", "", e.what());
    }
    running_ = false;
    ++progress_serial_;
}

json MeasurementJob::progress_json() const {
    const std::lock_guard lock(m_);
    return progress_;
}

json MeasurementJob::result_json() const {
    const std::lock_guard lock(m_);
    return result_;
}

}  // namespace piezoloop::ui
