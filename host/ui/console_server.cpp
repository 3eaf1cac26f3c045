#include "ui/console_server.hpp"

#include <httplib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <sstream>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "link/params_schema.hpp"
#include "ui/access.hpp"
#include "ui/commission_job.hpp"
#include "ui/control_seat.hpp"
#include "ui/frf_job.hpp"
#include "ui/measurement_job.hpp"
#include "ui/psd.hpp"
#include "ui/scope_view.hpp"
#include "ui/scan_job.hpp"
#include "ui/step_loops_job.hpp"
#include "ui/wall_clock.hpp"
#include "ui/web_assets.hpp"

namespace piezoloop::ui {

using nlohmann::json;

namespace {

void send_json(httplib::Response& res, const json& j, int status = 200) {
    res.status = status;
    res.set_content(j.dump(), "application/json");
}

std::string sse_event(const std::string& name, const json& data) {
    return "event: " + name + "\ndata: " + data.dump() + "\n\n";
}

}  // namespace

// One open page: its scope settings and frames.
struct ConsoleViewer {
    std::mutex m;
    ScopeSettings settings;
    ScopeView view;
    // The last frame the page reports drawn: the next frame waits until the
    // page has drawn the one before (kMaxFramesAhead), and is made from the
    // newest samples then; a slow page skips frames instead of queueing them
    // in the connection, which would add latency without bound.
    std::atomic<uint64_t> drawn{0};
};
constexpr uint64_t kMaxFramesAhead = 1;

struct ConsoleServer::Impl {
    BoardSession& board;
    ConsoleOptions options;
    AccessRules rules;
    httplib::Server server;
    ControlSeat seat;
    FrfJob frf;
    MeasurementJob step{"a step response"}, loops{"a hysteresis loop measurement"}, commissioning{"commissioning"},
        scanning{"a scan"};
    // The jobs whose progress and result the stream sends (events NAME and NAME-result).
    std::vector<std::pair<std::string, MeasurementJob*>> jobs = {
        {"step", &step}, {"loops", &loops}, {"commission", &commissioning}, {"scan", &scanning}};
    std::mutex viewers_m;
    std::map<std::string, std::shared_ptr<ConsoleViewer>> viewers;
    std::atomic<bool> stopping{false};
    int port = 0;

    Impl(BoardSession& b, ConsoleOptions o)
        : board(b), options(std::move(o)), seat(std::chrono::seconds(options.seat_answer_s)), frf(b) {}

    std::shared_ptr<ConsoleViewer> viewer(const std::string& id) {
        const std::lock_guard lock(viewers_m);
        const auto it = viewers.find(id);
        return it == viewers.end() ? nullptr : it->second;
    }

    // This viewer's view of the seat: whether it controls, and a pending
    // request for the seat (asked by it, or of it) with the seconds left.
    json control_json(const std::string& id) const {
        const auto holder = seat.holder();
        json j = {{"viewer", id}, {"controls", holder && *holder == id}, {"seat_taken", holder.has_value()},
                  {"viewers", seat.viewers()}, {"refused", seat.was_refused(id)}, {"request", nullptr}};
        if (const auto r = seat.request()) {
            const double left = std::chrono::duration<double>(r->deadline - ControlSeat::Clock::now()).count();
            j["request"] = {{"from_me", r->from == id}, {"to_me", holder && *holder == id},
                            {"seconds_left", std::max(0.0, left)}};
        }
        return j;
    }

    void routes();
    // Runs a request that changes the board: only for the seat's holder.
    void control(const std::string& pattern, std::function<json(const httplib::Request&)> body);
    json signals_json() const {
        json signals = json::array();
        for (const Signal& s : board.history().signals()) signals.push_back({{"name", s.name}, {"unit", s.unit}});
        return signals;
    }
};

void ConsoleServer::Impl::control(const std::string& pattern, std::function<json(const httplib::Request&)> body) {
    server.Post(pattern, [this, body](const httplib::Request& req, httplib::Response& res) {
        const std::string id = req.get_header_value("X-Piezoloop-Viewer");
        if (!seat.holds(id)) {
            send_json(res, {{"error", "another page controls the board (or this one has not taken control): "
                                      "this page watches"}},
                      409);
            return;
        }
        try {
            send_json(res, body(req));
        } catch (const FieldRefusal& e) {
            send_json(res, {{"error", e.what()}, {"field", e.field}}, 400);
        } catch (const BoardBusy& e) {
            send_json(res, {{"error", e.what()}}, 409);
        } catch (const std::invalid_argument& e) {
            send_json(res, {{"error", e.what()}}, 400);
        } catch (const json::exception& e) {
            send_json(res, {{"error", std::string("request: ") + e.what()}}, 400);
        } catch (const std::exception& e) {
            send_json(res, {{"error", e.what()}}, 502);
        }
    });
}

void ConsoleServer::Impl::routes() {
    server.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
        std::string token = req.get_header_value("X-Piezoloop-Token");
        if (token.empty()) token = req.get_param_value("token");
        std::optional<std::string> origin;
        if (req.has_header("Origin")) origin = req.get_header_value("Origin");
        const Verdict v = check_access(rules, req.get_header_value("Host"), origin, token);
        res.set_header("Cache-Control", "no-store");
        res.set_header("X-Content-Type-Options", "nosniff");
        res.set_header("X-Frame-Options", "DENY");
        res.set_header("Referrer-Policy", "no-referrer");
        if (v.ok()) return httplib::Server::HandlerResponse::Unhandled;
        res.status = v.http_status;
        res.set_content("refused: " + v.reason + "\n", "text/plain");
        return httplib::Server::HandlerResponse::Handled;
    });

    for (const WebAsset& a : web_assets()) {
        server.Get(std::string(a.path), [this, &a](const httplib::Request&, httplib::Response& res) {
            std::string body(a.body);
            // The page's own files carry the token in their URLs: a browser
            // sends no header with a <script src>.
            if (a.path == "/") {
                const std::string mark = "{{TOKEN}}";
                for (auto p = body.find(mark); p != std::string::npos; p = body.find(mark, p))
                    body.replace(p, mark.size(), rules.token);
            }
            res.set_header("Content-Security-Policy",
                           "default-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' blob: data:");
            res.set_content(body, std::string(a.content_type) + "; charset=utf-8");
        });
    }

    server.Get("/api/stream", [this](const httplib::Request&, httplib::Response& res) {
        const std::string id = seat.join();
        auto v = std::make_shared<ConsoleViewer>();
        {
            const std::lock_guard lock(viewers_m);
            viewers[id] = v;
        }
        struct StreamState {
            bool hello_sent = false;
            uint64_t status_serial = 0, frf_serial = 0, frf_result_serial = 0, seat_serial = 0, signals_generation = 0;
            std::map<std::string, std::pair<uint64_t, uint64_t>> job_serials;  // progress, result
            std::chrono::steady_clock::time_point last_frame{}, last_write{};
        };
        auto state = std::make_shared<StreamState>();
        res.set_chunked_content_provider(
            "text/event-stream",
            [this, id, v, state](size_t, httplib::DataSink& sink) {
                if (stopping) return false;
                using clock = std::chrono::steady_clock;
                std::string out;
                if (!state->hello_sent) {
                    state->signals_generation = board.history().generation();
                    json hello = control_json(id);
                    hello["signals"] = signals_json();
                    hello["channel_choices"] = board.channel_choices();
                    hello["channel_capacity"] = board.channel_capacity();
                    hello["rate_Hz"] = board.history().rate_Hz();
                    hello["simulator"] = !options.scenario.empty();  // commissioning may run simulated
                    hello["axes"] = json::array();  // the board's axes by name
                    for (int a = 0; a < board.axis_count(); ++a) hello["axes"].push_back(std::string(1, "xyz"[a]));
                    {
                        const std::lock_guard lock(v->m);
                        hello["scope"] = to_json(v->settings);
                    }
                    out += sse_event("hello", hello);
                    state->hello_sent = true;
                } else {
                    std::this_thread::sleep_for(std::chrono::milliseconds(4));
                }
                // Other channels: the page's scope starts again with them (a
                // trigger on a signal no longer recorded moves to the first).
                if (const uint64_t g = board.history().generation(); g != state->signals_generation) {
                    state->signals_generation = g;
                    const json signals = signals_json();
                    json scope;
                    {
                        const std::lock_guard lock(v->m);
                        if (!board.history().find(v->settings.trigger_signal) && !signals.empty())
                            v->settings.trigger_signal = signals[0]["name"];
                        scope = to_json(v->settings);
                    }
                    out += sse_event("signals", {{"signals", signals}, {"scope", scope}});
                }
                const auto now = clock::now();
                if (now - state->last_frame >= std::chrono::microseconds(static_cast<int>(1e6 / kFramesPerSecond))) {
                    std::optional<json> frame;
                    {
                        const std::lock_guard lock(v->m);
                        // A page silent for a second (a lost report, a hidden
                        // tab) gets a frame anyway.
                        if (v->view.last_seq() < v->drawn + kMaxFramesAhead ||
                            now - state->last_frame > std::chrono::seconds(1))
                            frame = v->view.next_frame(board.history(), v->settings, wall_clock_ms());
                    }
                    if (frame) {
                        out += sse_event("frame", *frame);
                        state->last_frame = now;
                    }
                }
                // The seat: a request unanswered in time passes it.
                seat.expire(ControlSeat::Clock::now());
                if (const uint64_t ss = seat.serial(); ss != state->seat_serial) {
                    state->seat_serial = ss;
                    out += sse_event("control", control_json(id));
                }
                const uint64_t serial = board.status_serial();
                if (serial != state->status_serial) {
                    state->status_serial = serial;
                    json st = board.status_json();
                    st["control"] = control_json(id);
                    out += sse_event("status", st);
                }
                // The measurement's progress, and its result once (every page
                // gets the latest of both when it connects).
                if (const uint64_t fs = frf.progress_serial(); fs != state->frf_serial) {
                    state->frf_serial = fs;
                    out += sse_event("frf", frf.progress_json());
                }
                if (const uint64_t rs = frf.result_serial(); rs != state->frf_result_serial) {
                    state->frf_result_serial = rs;
                    out += sse_event("frf-result", frf.result_json());
                }
                for (const auto& [name, job] : jobs) {
                    auto& [ps, rs] = state->job_serials[name];
                    if (const uint64_t p = job->progress_serial(); p != ps) {
                        ps = p;
                        out += sse_event(name, job->progress_json());
                    }
                    if (const uint64_t r = job->result_serial(); r != rs) {
                        rs = r;
                        out += sse_event(name + "-result", job->result_json());
                    }
                }
                // A comment now and then: finds a closed connection.
                if (out.empty() && now - state->last_write > std::chrono::seconds(1)) out = ": idle\n\n";
                if (out.empty()) return true;
                state->last_write = now;
                return sink.write(out.data(), out.size());
            },
            [this, id](bool) {
                seat.leave(id);
                const std::lock_guard lock(viewers_m);
                viewers.erase(id);
            });
    });

    server.Post("/api/scope", [this](const httplib::Request& req, httplib::Response& res) {
        const auto v = viewer(req.get_header_value("X-Piezoloop-Viewer"));
        if (!v) return send_json(res, {{"error", "unknown viewer: open the live stream first"}}, 400);
        try {
            const json j = json::parse(req.body);
            const std::lock_guard lock(v->m);
            v->settings = merge_scope_settings(j, v->settings, board.history());
            send_json(res, to_json(v->settings));
        } catch (const std::exception& e) {
            send_json(res, {{"error", e.what()}}, 400);
        }
    });

    server.Post("/api/scope/drawn", [this](const httplib::Request& req, httplib::Response& res) {
        const auto v = viewer(req.get_header_value("X-Piezoloop-Viewer"));
        if (!v) return send_json(res, {{"error", "unknown viewer: open the live stream first"}}, 400);
        try {
            // Reports may arrive out of order (separate connections): the latest frame counts.
            const uint64_t seq = json::parse(req.body).at("seq").get<uint64_t>();
            uint64_t seen = v->drawn.load();
            while (seq > seen && !v->drawn.compare_exchange_weak(seen, seq)) {
            }
            send_json(res, json::object());
        } catch (const std::exception& e) {
            send_json(res, {{"error", std::string("seq: ") + e.what()}}, 400);
        }
    });

    server.Get("/api/scope/csv", [this](const httplib::Request& req, httplib::Response& res) {
        try {
            const double t0 = std::stod(req.get_param_value("t0_s"));
            const double span = std::stod(req.get_param_value("span_s"));
            if (!(span > 0.0 && span <= 60.0)) throw std::invalid_argument("span_s: must be in (0, 60]");
            res.set_header("Content-Disposition", "attachment; filename=\"scope.csv\"");
            res.set_content(window_csv(board.history(), t0, span), "text/csv");
        } catch (const std::exception& e) {
            send_json(res, {{"error", std::string("t0_s, span_s: ") + e.what()}}, 400);
        }
    });

    // The scope's cursors: ?t_s=A&t_s=B, each the nearest sample's time and values.
    server.Get("/api/scope/cursors", [this](const httplib::Request& req, httplib::Response& res) {
        try {
            const std::size_t n = req.get_param_value_count("t_s");
            if (n < 1 || n > 2) throw std::invalid_argument("t_s: give one or two times (s)");
            json out = json::array();
            for (std::size_t i = 0; i < n; ++i) out.push_back(cursor_sample(board.history(), std::stod(req.get_param_value("t_s", i))));
            send_json(res, {{"cursors", out}});
        } catch (const std::exception& e) {
            send_json(res, {{"error", std::string("t_s: ") + e.what()}}, 400);
        }
    });

    server.Get("/api/scope/psd", [this](const httplib::Request& req, httplib::Response& res) {
        try {
            const std::string name = req.get_param_value("signal");
            const double t0 = std::stod(req.get_param_value("t0_s"));
            const double span = std::stod(req.get_param_value("span_s"));
            if (!(span > 0.0 && span <= 60.0)) throw std::invalid_argument("span_s: must be in (0, 60]");
            const auto segment = static_cast<std::size_t>(std::stoul(req.get_param_value("segment")));
            const SampleWindow w = board.history().window(t0, span);
            const auto sig = std::find_if(w.signals.begin(), w.signals.end(), [&](const Signal& s) { return s.name == name; });
            if (sig == w.signals.end()) throw std::invalid_argument("signal: '" + name + "' is not a recorded signal");
            const auto k = static_cast<std::size_t>(sig - w.signals.begin());
            const Psd p = welch_psd(w.values[k], board.history().rate_Hz(), segment);
            const std::string unit = sig->unit;
            send_json(res, {{"signal", name}, {"unit", unit + "^2/Hz"}, {"segment", p.segment},
                            {"segments", p.segments}, {"frequency_Hz", p.frequency_Hz}, {"density", p.density}});
        } catch (const std::exception& e) {
            send_json(res, {{"error", e.what()}}, 400);
        }
    });

    // ?axis=x|y|z on a board of axes: that axis's groups.
    server.Get("/api/params", [this](const httplib::Request& req, httplib::Response& res) {
        try {
            const uint8_t axis = board.axis_index(req.get_param_value("axis"));
            const json schema = hostlink::parameter_schema();
            json groups = json::object();
            for (const std::string& g : BoardSession::form_groups()) groups[g] = schema["properties"][g];
            send_json(res, {{"groups", BoardSession::form_groups()}, {"schema", groups}, {"values", board.groups_json(axis)},
                            {"axis", req.get_param_value("axis")}});
        } catch (const std::invalid_argument& e) {
            send_json(res, {{"error", e.what()}}, 400);
        } catch (const BoardBusy& e) {
            send_json(res, {{"error", e.what()}}, 409);
        } catch (const std::exception& e) {
            send_json(res, {{"error", e.what()}}, 502);
        }
    });

    // Takes the free seat, or asks its holder (202: the answer, or the
    // timeout, comes on the stream).
    server.Post("/api/control/claim", [this](const httplib::Request& req, httplib::Response& res) {
        const std::string id = req.get_header_value("X-Piezoloop-Viewer");
        const ControlSeat::Asked a = seat.ask(id, ControlSeat::Clock::now());
        json j = control_json(id);
        if (a == ControlSeat::Asked::kRefused)
            j["error"] = seat.request() ? "another page is asking for control already: this page watches"
                                        : "unknown viewer: open the live stream first";
        send_json(res, j, a == ControlSeat::Asked::kTaken ? 200 : a == ControlSeat::Asked::kAsked ? 202 : 409);
    });
    // The holder's answer to a request for the seat: {give: true|false}.
    server.Post("/api/control/answer", [this](const httplib::Request& req, httplib::Response& res) {
        const std::string id = req.get_header_value("X-Piezoloop-Viewer");
        const json body = json::parse(req.body, nullptr, false);
        if (!body.is_object() || !body.contains("give") || !body["give"].is_boolean())
            return send_json(res, {{"error", "give: must be true or false"}}, 400);
        const bool ok = seat.answer(id, body["give"].get<bool>());
        json j = control_json(id);
        if (!ok) j["error"] = "nothing to answer: this page does not control the board, or nobody is asking";
        send_json(res, j, ok ? 200 : 409);
    });
    server.Post("/api/control/release", [this](const httplib::Request& req, httplib::Response& res) {
        const std::string id = req.get_header_value("X-Piezoloop-Viewer");
        seat.release(id);
        send_json(res, control_json(id));
    });

    control("/api/arm", [this](const httplib::Request&) {
        board.arm();
        return board.status_json();
    });
    control("/api/disarm", [this](const httplib::Request&) {
        board.disarm();
        return board.status_json();
    });
    control("/api/clear-trip", [this](const httplib::Request&) {
        board.clear_trip();
        return board.status_json();
    });
    control("/api/stop", [this](const httplib::Request&) {
        // Stop stops a measurement too (its excitation ends, the groups go back).
        for (const auto& j : jobs)
            if (j.second->running()) j.second->request_stop();
        if (board.measuring()) {
            frf.request_stop();
            return board.status_json();
        }
        board.stop_motion();
        return board.status_json();
    });
    // The scope's channels: {"channels": ["r", "y", "y.u", ...]}.
    control("/api/scope/channels", [this](const httplib::Request& req) {
        const json j = json::parse(req.body, nullptr, false);
        if (!j.is_object() || !j.contains("channels") || !j["channels"].is_array() ||
            !std::all_of(j["channels"].begin(), j["channels"].end(), [](const json& c) { return c.is_string(); }))
            throw FieldRefusal("channels", "channels: a list of channel names, such as [\"r\", \"y\", \"y.u\"]");
        if (j.size() != 1) throw FieldRefusal("", "only channels may be given");
        try {
            board.set_scope_channels(j["channels"].get<std::vector<std::string>>());
        } catch (const std::invalid_argument& e) {
            throw FieldRefusal("channels", e.what());
        }
        return json{{"signals", signals_json()}};
    });
    control(R"(/api/params/([a-z_]+))", [this](const httplib::Request& req) {
        return board.set_group(req.matches[1], json::parse(req.body), board.axis_index(req.get_param_value("axis")))
            .to_json();
    });
    control("/api/wave", [this](const httplib::Request& req) { return board.start_wave(json::parse(req.body)); });

    control("/api/frf/start", [this](const httplib::Request& req) {
        const json form = json::parse(req.body, nullptr, false);
        if (form.is_discarded()) throw FieldRefusal("", "the request is not JSON");
        return frf.start(form);
    });
    control("/api/frf/stop", [this](const httplib::Request&) {
        frf.request_stop();
        return frf.progress_json();
    });
    // Steps and loops: started by the controlling page only, refused at
    // their fields before anything moves.
    const std::pair<std::string, MeasurementJob::Work (*)(BoardSession&, const json&)> starts[] = {
        {"step", step_work}, {"loops", loops_work}};
    for (const auto& [name, work] : starts) {
        MeasurementJob* job = name == "step" ? &step : &loops;
        control("/api/" + name + "/start", [this, job, work](const httplib::Request& req) {
            const json form = json::parse(req.body, nullptr, false);
            if (form.is_discarded()) throw FieldRefusal("", "the request is not JSON");
            return job->start(form, work(board, form));
        });
        control("/api/" + name + "/stop", [job](const httplib::Request&) {
            job->request_stop();
            return job->progress_json();
        });
        server.Get("/api/" + name, [job](const httplib::Request&, httplib::Response& res) {
            send_json(res, {{"progress", job->progress_json()}, {"result", job->result_json()}});
        });
        server.Get("/api/" + name + "/csv", [job, name](const httplib::Request&, httplib::Response& res) {
            const json r = job->result_json();
            const std::string csv = name == "step" ? step_csv(r) : loops_csv(r);
            if (csv.empty()) return send_json(res, {{"error", "nothing measured yet"}}, 404);
            res.set_header("Content-Disposition", "attachment; filename=\"" + name + ".csv\"");
            res.set_content(csv, "text/csv");
        });
    }

    // A scan (a board of two or three axes): the console's scenario, if
    // any, is the stage the board drives.
    control("/api/scan/start", [this](const httplib::Request& req) {
        const json form = json::parse(req.body, nullptr, false);
        if (form.is_discarded()) throw FieldRefusal("", "the request is not JSON");
        return scanning.start(form, scan_work(board, options.scenario, form));
    });
    control("/api/scan/stop", [this](const httplib::Request&) {
        scanning.request_stop();
        return scanning.progress_json();
    });
    server.Get("/api/scan", [this](const httplib::Request&, httplib::Response& res) {
        send_json(res, {{"progress", scanning.progress_json()}, {"result", scanning.result_json()}});
    });
    control("/api/commission/start", [this](const httplib::Request& req) {
        const json form = json::parse(req.body, nullptr, false);
        if (form.is_discarded()) throw FieldRefusal("", "the request is not JSON");
        return commissioning.start(form, commission_work(board, options.scenario, form));
    });
    control("/api/commission/stop", [this](const httplib::Request&) {
        commissioning.request_stop();
        return commissioning.progress_json();
    });
    server.Get("/api/commission", [this](const httplib::Request&, httplib::Response& res) {
        send_json(res, {{"progress", commissioning.progress_json()}, {"result", commissioning.result_json()},
                        {"simulator", !options.scenario.empty()}});
    });
    server.Get(R"(/api/commission/figure/((?:[xyz]/)?[a-z]+\.png))", [this](const httplib::Request& req, httplib::Response& res) {
        const std::string path = commission_figure_path(commissioning.result_json(), req.matches[1]);
        std::ifstream f(path, std::ios::binary);
        if (path.empty() || !f) return send_json(res, {{"error", "no such figure in the last commissioning"}}, 404);
        std::ostringstream body;
        body << f.rdbuf();
        res.set_content(body.str(), "image/png");
    });

    server.Get("/api/frf", [this](const httplib::Request&, httplib::Response& res) {
        send_json(res, {{"progress", frf.progress_json()}, {"result", frf.result_json()}});
    });
    server.Get("/api/frf/csv", [this](const httplib::Request&, httplib::Response& res) {
        const std::string csv = frf.result_csv();
        if (csv.empty()) return send_json(res, {{"error", "no frequency response measured yet"}}, 404);
        res.set_header("Content-Disposition", "attachment; filename=\"frf.csv\"");
        res.set_content(csv, "text/csv");
    });
}

ConsoleServer::ConsoleServer(BoardSession& board, ConsoleOptions options)
    : impl_(std::make_unique<Impl>(board, std::move(options))) {}

ConsoleServer::~ConsoleServer() {
    impl_->stopping = true;
    impl_->server.stop();
}

int ConsoleServer::bind() {
    Impl& s = *impl_;
    // Each page holds a worker for its stream, and a browser keeps several
    // connections open: more workers than cpp-httplib's default.
    s.server.new_task_queue = [] { return new httplib::ThreadPool(32); };
    s.server.set_keep_alive_timeout(2);
    // Frames and the pages' small reports go out at once, not held for
    // coalescing (Nagle's algorithm would delay a report's reply).
    s.server.set_tcp_nodelay(true);
    if (s.options.port == 0) {
        s.port = s.server.bind_to_any_port(s.options.bind_address);
        if (s.port <= 0) throw std::runtime_error("cannot bind a port on " + s.options.bind_address);
    } else {
        if (!s.server.bind_to_port(s.options.bind_address, s.options.port))
            throw std::runtime_error("cannot bind " + s.options.bind_address + ":" + std::to_string(s.options.port) +
                                     " (in use?)");
        s.port = s.options.port;
    }
    s.rules = access_rules(random_hex(kTokenBytes), s.port, s.options.bind_address);
    s.routes();
    return s.port;
}

std::string ConsoleServer::url() const {
    return "http://127.0.0.1:" + std::to_string(impl_->port) + "/?token=" + impl_->rules.token;
}

void ConsoleServer::serve(const std::function<bool()>& stop_requested) {
    Impl& s = *impl_;
    std::thread listener([&s] { s.server.listen_after_bind(); });
    while (!stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    s.stopping = true;
    s.frf.shutdown();  // a running measurement stops, the board's groups put back
    for (const auto& j : s.jobs) j.second->shutdown();
    s.server.stop();
    listener.join();
}

}  // namespace piezoloop::ui
