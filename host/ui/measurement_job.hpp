// One kind of measurement the console runs on the board in a worker thread
// (steps, loops, commissioning): its progress and its last result, both
// sent to every page, and a stop. The work checks its request before it is
// started (the caller's part, so a refusal comes back with the HTTP reply)
// and reports its phase and fraction as it goes.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

namespace piezoloop::ui {

class MeasurementJob {
public:
    // What the work is given: report(phase, fraction) its phase
    // ("recording", "analysing", ...) and the fraction of it done, 0 to 1;
    // note(line) a line for the progress's log (a decision, a step done);
    // stop_requested() says when to give up.
    struct Context {
        std::function<void(const std::string& phase, double fraction)> report;
        std::function<void(const std::string& line)> note;
        std::function<bool()> stop_requested;
    };
    // Runs the measurement and returns its result. Throws FieldRefusal
    // (shown at the field), hostlink::DeviceError (the board's refusal) or
    // any std::exception.
    using Work = std::function<nlohmann::json(const Context& context)>;

    // `what` names the measurement in messages ("a step response").
    explicit MeasurementJob(std::string what) : what_(std::move(what)) {}
    ~MeasurementJob();
    MeasurementJob(const MeasurementJob&) = delete;
    MeasurementJob& operator=(const MeasurementJob&) = delete;

    // Starts `work` for `request` (kept in the progress); BoardBusy while
    // one runs.
    nlohmann::json start(const nlohmann::json& request, Work work);
    void request_stop() { stop_ = true; }
    void shutdown();  // stops a running measurement and waits for it
    bool running() const { return running_.load(); }

    // {state: idle|running|done|failed|stopped, phase, fraction, request,
    //  log: [line, ...] (the notes), error: {field, message}}
    nlohmann::json progress_json() const;
    uint64_t progress_serial() const { return progress_serial_.load(); }
    nlohmann::json result_json() const;  // null before the first
    uint64_t result_serial() const { return result_serial_.load(); }

private:
    void run(Work work);
    void set_progress(const std::string& state, const std::string& phase, double fraction);
    void fail(const std::string& state, const std::string& field, const std::string& message);

    std::string what_;
    std::thread worker_;
    std::atomic<bool> running_{false}, stop_{false};
    std::mutex start_m_;
    mutable std::mutex m_;
    nlohmann::json progress_ = {{"state", "idle"}};
    nlohmann::json result_;
    std::atomic<uint64_t> progress_serial_{1}, result_serial_{1};
};

}  // namespace piezoloop::ui
