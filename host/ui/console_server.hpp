// The console's HTTP server: the page (ui/web_assets), the live stream as
// server-sent events (per page: its viewer id, scope frames at up to
// kFramesPerSecond, the board's status when it changes), and the JSON API
// the page calls. Every request passes ui/access's checks first; requests
// that change the board need the control seat (ui/control_seat).
//
//   GET  /                          the page (needs ?token=)
//   GET  /api/stream?token=         text/event-stream: hello, frame, status
//   POST /api/scope                 this viewer's scope settings (JSON)
//   GET  /api/scope/csv?t0_s=&span_s=   the samples of a window as CSV
//   GET  /api/params                schema of the form groups and their values
//   POST /api/control/claim|release the control seat (claim asks its
//                                   holder when taken); /api/control/answer
//                                   the holder's {give}; the stream's control
//   POST /api/arm|disarm|clear-trip|stop, /api/params/GROUP, /api/wave
//   POST /api/frf/start|stop        a frequency response (ui/frf_job); the
//                                   stream's frf and frf-result events
//   GET  /api/frf, /api/frf/csv     its progress and last result
//   POST /api/step|loops/start|stop a step response, hysteresis loops
//                                   (ui/step_loops_job); events step,
//                                   step-result, loops, loops-result
//   GET  /api/step|loops[/csv]      their progress and last result
//   POST /api/commission/start|stop commissioning (ui/commission_job)
//   GET  /api/commission, /api/commission/figure/NAME.png
// The viewer id goes in the X-Piezoloop-Viewer header, the token in
// X-Piezoloop-Token (or ?token= where a header cannot be set).
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "ui/board_session.hpp"

namespace piezoloop::ui {

struct ConsoleOptions {
    std::string bind_address = "127.0.0.1";
    int port = 0;  // 0: a free one
    std::string scenario;  // `ui --scenario`: its stage may also be commissioned simulated
    int seat_answer_s = 10;  // how long a controlling page has to answer a request for the seat
};

class ConsoleServer {
public:
    static constexpr double kFramesPerSecond = 50.0;

    ConsoleServer(BoardSession& board, ConsoleOptions options);
    ~ConsoleServer();

    // Binds the port (std::runtime_error when it cannot) and returns it.
    int bind();
    std::string url() const;  // with the token
    // Serves until stop_requested() returns true (polled every 100 ms).
    void serve(const std::function<bool()>& stop_requested);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace piezoloop::ui
