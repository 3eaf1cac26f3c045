// piezoloop.connect: a board over the link (host/link/client.hpp), with the
// same calls the command line's device subcommands make (cli/cmd_device.cpp,
// cli/device_common.hpp), so a Python session and `piezoloop --device` agree.
// Every blocking request runs without the GIL.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "commission_session.hpp"
#include "device_common.hpp"
#include "link/client.hpp"
#include "link/measure_session.hpp"
#include "link/mimo_measure_session.hpp"
#include "measure/frf_report.hpp"
#include "link/params_json.hpp"
#include "link/record_session.hpp"
#include "link/scan_session.hpp"
#include "link/transport.hpp"
#include "options/option_checks.hpp"
#include "piezoloop/params/groups.hpp"

namespace piezoloop::py {
namespace {

using hostlink::Client;
using nlohmann::json;

// Ctrl-C during a blocking session: Python's handler only flags the
// signal; the session polls poll() (from its thread without the GIL), stops
// what runs on the board and keeps what arrived, and raise_if_interrupted()
// raises the KeyboardInterrupt once the board is left clean.
class Interrupt {
public:
    std::function<bool()> poll() {
        return [this] {
            pyb::gil_scoped_acquire acquire;
            if (PyErr_CheckSignals() != 0) {
                PyErr_Clear();
                interrupted_ = true;
            }
            return interrupted_;
        };
    }
    bool interrupted() const { return interrupted_; }
    void raise_if_interrupted() const {
        if (!interrupted_) return;
        PyErr_SetNone(PyExc_KeyboardInterrupt);
        throw pyb::error_already_set();
    }

private:
    bool interrupted_ = false;
};

json board_source(Client& c, const measure::MeasureBounds& b) {
    return {{"kind", "board"}, {"device", c.address()}, {"board", c.info().board.data()}, {"rate_Hz", b.rate_Hz}};
}

class Device {
public:
    Device(const std::string& address, int timeout_ms) {
        pyb::gil_scoped_release release;
        Client::Options o;
        o.timeout = std::chrono::milliseconds(timeout_ms);
        client_ = std::make_unique<Client>(hostlink::open_transport(address), o);
        client_->hello();
    }

    Client& client() {
        if (!client_) throw hostlink::LinkError("the device is closed");
        return *client_;
    }

    // An axis by name ("" on a one-axis board: its axis), as the command
    // line's --axis, the error naming `axis`. all: "all" is every axis
    // (cli::kAllAxes).
    int axis_of(const std::string& name, bool all = false) {
        try {
            return cli::resolve_axis(name, client().axis_count(), all);
        } catch (const std::invalid_argument& e) {
            const std::string m = e.what();
            throw std::invalid_argument(m.rfind("--axis", 0) == 0 ? m.substr(2) : m);
        }
    }
    void close() { client_.reset(); }

    pyb::object status() {
        json out;
        {
            pyb::gil_scoped_release release;
            Client& c = client();
            out = {{"device", c.address()}, {"hello", hostlink::to_json(c.info())},
                   {"status", hostlink::to_json(c.status())}};
        }
        return to_python(out);
    }

    pyb::object get(const std::string& group, const std::string& axis) {
        const link::ParamGroup g = hostlink::parse_group(group);
        json out;
        {
            pyb::gil_scoped_release release;
            out = get_group(g, group_axis(g, axis));
        }
        return to_python(out);
    }

    // The fields merged onto the board's group, sent only if something
    // changed (as `piezoloop set GROUP --json`); the group as read back. A
    // refused group leaves the board's unchanged (the board checks a group
    // whole before swapping it in).
    pyb::object set(const std::string& group, const std::string& fields_json, const std::string& axis) {
        const link::ParamGroup g = hostlink::parse_group(group);
        const json fields = json::parse(fields_json);
        json out;
        {
            pyb::gil_scoped_release release;
            const uint8_t a = group_axis(g, axis);
            params::with_group(g, [&](auto tag) {
                using G = typename decltype(tag)::type;
                const G current = client().get<G>(a);
                G v = current;
                hostlink::merge_json(fields, v);
                if (!(v == current)) client().set(v, a);
            });
            out = get_group(g, a);
        }
        return to_python(out);
    }

    pyb::object set_scenario(const std::string& scenario, const std::string& case_name, double frequency_Hz) {
        json out;
        std::vector<std::string> lines;
        {
            pyb::gil_scoped_release release;
            out = cli::send_scenario_case(client(), scenario, case_name, frequency_Hz,
                                          [&](const std::string& line) { lines.push_back(line); });
        }
        // The clipped fields are in "clipped" already; other remarks (the
        // sample type the case was built for) join the notes.
        for (const std::string& l : lines)
            if (l.rfind("clipped: ", 0) != 0) out["notes"].push_back(l);
        return to_python(out);
    }

    void simple(void (Client::*f)()) {
        pyb::gil_scoped_release release;
        (client().*f)();
    }

    pyb::dict record(const std::string& signals, double duration_s, double decimation, bool start_wave,
                     bool restart_stage, std::optional<cli::WaveRequest> wave, double stall_s,
                     const std::string& out_csv, const std::string& axis, bool every_axis) {
        hostlink::RecordOptions o;
        o.signals = hostlink::parse_signal_list(signals);
        if (restart_stage && !start_wave) throw std::invalid_argument("restart_stage: only with start_wave");
        if (every_axis && !start_wave) throw std::invalid_argument("every_axis: only with start_wave");
        o.axis = static_cast<uint8_t>(axis_of(axis));
        o.every_axis = every_axis;
        options::check_record_options(duration_s, decimation, stall_s);
        o.duration_s = duration_s;
        o.decimation = static_cast<uint32_t>(decimation);
        o.start_wave = start_wave;
        o.restart_stage = restart_stage;
        o.stall_s = stall_s;
        o.out_csv = out_csv;
        if (wave) o.wave = cli::wave_params(*wave, client().info().loop_rate_Hz);
        Interrupt ctrl_c;
        o.stop_requested = ctrl_c.poll();
        hostlink::RecordResult r;
        {
            pyb::gil_scoped_release release;
            r = hostlink::record(client(), o);
        }
        ctrl_c.raise_if_interrupted();
        pyb::dict sig;
        sig["t_s"] = pyb::array_t<double>(static_cast<pyb::ssize_t>(r.t_s.size()), r.t_s.data());
        for (std::size_t k = 0; k < r.signals.size(); ++k) {
            const std::string name = std::string(hostlink::signal_name(r.signals[k])) + "_" +
                                     hostlink::signal_unit(r.signals[k]);
            sig[pyb::str(name)] =
                pyb::array_t<double>(static_cast<pyb::ssize_t>(r.values[k].size()), r.values[k].data());
        }
        pyb::dict out;
        out["signals"] = sig;
        out["summary"] = to_python(hostlink::summary_json(r));
        return out;
    }

    // A measurement session (link/measure_session) with Ctrl-C: body(client,
    // options) runs without the GIL; Ctrl-C stops what runs on the board,
    // which the session leaves clean (excitation stopped, groups put back),
    // and then raises KeyboardInterrupt.
    template <class Body>
    void measure_session(bool restart_stage, const std::string& axis, Body body) {
        Interrupt ctrl_c;
        hostlink::MeasureOptions o;
        o.restart_stage = restart_stage;
        o.axis = static_cast<uint8_t>(axis_of(axis));
        o.stop_requested = ctrl_c.poll();
        try {
            pyb::gil_scoped_release release;
            body(client(), o);
        } catch (const hostlink::LinkError&) {
            if (!ctrl_c.interrupted()) throw;
        }
        ctrl_c.raise_if_interrupted();
    }

    // `piezoloop --device measure frf`: the JSON of frf_report.
    pyb::object measure_frf(const measure::FrfRequest& r, bool restart_stage, const std::string& axis) {
        json out;
        measure_session(restart_stage, axis, [&](Client& c, const hostlink::MeasureOptions& o) {
            const hostlink::DeviceFrfRun d = hostlink::run_frf_device(c, r, o);
            out = measure::frf_report(r, d.run, {{"kind", "board"}, {"device", c.address()},
                                                 {"board", c.info().board.data()}});
            out["recording"] = hostlink::recording_summary(d.record);
            if (c.axis_count() > 1) out["source"]["axis"] = axis;
        });
        return to_python(out);
    }

    // `piezoloop --device measure step`: the JSON `measure step --out`
    // writes; a closed-loop step starts from the setpoint the board holds
    // unless from_um is given.
    pyb::object measure_step(const measure::StepInput& so, bool restart_stage, const std::string& axis) {
        json out;
        measure_session(restart_stage, axis, [&](Client& c, const hostlink::MeasureOptions& o) {
            const measure::MeasureBounds b = hostlink::board_bounds(c, o.axis);
            std::optional<double> setpoint_um;
            if (!so.from_um) setpoint_um = c.status().axis_r_um[o.axis];
            const measure::StepRequest r = measure::step_request(so, b, setpoint_um);
            out = measure::step_report(r, hostlink::run_step_device(c, r, o), board_source(c, b));
        });
        return to_python(out);
    }

    // `piezoloop --device measure loops`: as piezoloop.measure_loops.
    pyb::object measure_loops(const std::vector<double>& amplitudes_V, std::optional<double> base_V,
                              double frequency_Hz, int cycles, const std::string& shape, bool restart_stage,
                              const std::string& axis) {
        measure::LoopsRequest r;
        measure::LoopsRun run;
        json source;
        measure_session(restart_stage, axis, [&](Client& c, const hostlink::MeasureOptions& o) {
            const measure::MeasureBounds b = hostlink::board_bounds(c, o.axis);
            r = measure::loops_request(amplitudes_V, base_V, frequency_Hz, cycles, shape, b);
            run = hostlink::run_loops_device(c, r, o);
            source = board_source(c, b);
        });
        return loops_result(run, measure::loops_report(r, run, source));
    }

    // `piezoloop --device commission`: as piezoloop.commission, on the board;
    // the progress lines go to `progress` (with the GIL) when given.
    // `measure frf --mimo` on a board of axes: one axis at a time
    // (hostlink::run_mimo_frf_device), through the board's output matrix.
    pyb::dict measure_frf_mimo(double from_Hz, double to_Hz, double amplitude_V, double bias_V, int periods,
                               int transient_periods) {
        json report;
        hostlink::DeviceMimoFrfRun run;
        {
            pyb::gil_scoped_release release;
            Client& c = client();
            // Errors name the command line's options, as measure_frf's do.
            const measure::MimoFrfRequest r =
                hostlink::board_mimo_request(c, from_Hz, to_Hz, amplitude_V, bias_V, periods, transient_periods);
            run = hostlink::run_mimo_frf_device(c, r);
            report = hostlink::board_mimo_report(c, run);
        }
        pyb::dict out = estimate_dict(run.estimate);
        out["report"] = to_python(report);
        return out;
    }

    // A scan on a board of two or three axes (`piezoloop --device ADDR
    // scan`); the scenario (may be empty) is the stage the board drives.
    pyb::dict scan(const scan::ScanRequest& r, const std::string& scenario, bool restart_stage,
                   bool rc_period_from_scan) {
        hostlink::BoardScan b;
        {
            pyb::gil_scoped_release release;
            std::optional<sim::Scenario> stage;
            if (!scenario.empty()) stage = sim::load_scenario(scenario);
            hostlink::BoardScanOptions o;
            o.restart_stage = restart_stage;
            o.rc_period_from_scan = rc_period_from_scan;
            b = hostlink::scan_on_board(client(), r, stage ? &*stage : nullptr,
                                        [](const std::string& field) { return field; }, o);
        }
        if (!b.problems.empty()) throw hostlink::LinkError("scan incomplete:" + b.problems);
        return scan_result(b.outcome);
    }

    pyb::object commission(double range_um, double target_bandwidth_Hz, const std::string& out, bool save,
                           const pyb::object& progress, const std::string& axis) {
        cli::CommissionSession s;
        s.axis = axis;
        s.request.range_um = range_um;
        s.request.target_bandwidth_Hz = target_bandwidth_Hz;
        s.out = out;
        s.save = save;
        json summary;
        measure_session(false, axis, [&](Client& c, const hostlink::MeasureOptions& o) {
            summary = cli::run_commission_session(&c, s, progress_lines(progress), o.stop_requested);
        });
        return to_python(summary);
    }

    // `piezoloop wave`: the trajectory group set and started, detached (it
    // runs on when this client goes quiet); arm: the loop armed at its
    // first tick (it must be disarmed).
    pyb::object wave(const cli::WaveRequest& w, bool arm, const std::string& axis) {
        json out;
        {
            pyb::gil_scoped_release release;
            Client& c = client();
            const auto a = static_cast<uint8_t>(axis_of(axis));
            c.set(cli::wave_params(w, c.info().loop_rate_Hz), a);
            if (c.status().axis_wave_running[a]) c.stop_wave(a);
            c.start_wave(hostlink::wave_flag::kDetached | (arm ? hostlink::wave_flag::kArm : 0), a);
            const link::StatusReply st = c.status();
            out = {{"trajectory", hostlink::to_json(c.get<link::TrajectoryParams>(a))},
                   {"wave_running", st.axis_wave_running[a]},
                   {"armed", st.axis_armed[a]}};
            if (c.axis_count() > 1) out["axis"] = cli::axis_name(a);
        }
        return to_python(out);
    }

    // `piezoloop stop`: the wave and the stream stopped, the setpoint holds.
    pyb::object stop() {
        json out;
        {
            pyb::gil_scoped_release release;
            Client& c = client();
            c.stop_waves();
            c.stream_stop(false);
            const link::StatusReply st = c.status();
            out = {{"wave_running", st.wave_running}, {"streaming", st.streaming}, {"armed", st.armed}};
        }
        return to_python(out);
    }

    // `piezoloop stream`: every setpoint consumed by the tick, the stream
    // drained. Ctrl-C closes the stream on the board (the setpoint holds its
    // last value, the loop stays as it was), then KeyboardInterrupt.
    pyb::object stream(const std::vector<float>& setpoints_um, std::optional<double> prefill) {
        struct Interrupted {};
        Interrupt ctrl_c;
        const std::function<bool()> poll = ctrl_c.poll();
        json out;
        (void)options::stream_prefill(prefill, 0, 0);  // refused before the board is contacted
        try {
            pyb::gil_scoped_release release;
            Client& c = client();
            const uint16_t pre = options::stream_prefill(prefill, c.info().setpoint_capacity, setpoints_um.size());
            const hostlink::StreamResult r = c.stream(setpoints_um, pre, [&](double) {
                if (poll()) throw Interrupted{};
            });
            out = {{"setpoints", setpoints_um.size()}, {"sent", r.sent},         {"consumed", r.consumed},
                   {"underruns", r.underruns},          {"blocks", r.blocks},     {"prefill", pre},
                   {"capacity", r.capacity},            {"drained", r.drained},   {"wall_s", r.wall_s}};
        } catch (const Interrupted&) {
        }
        ctrl_c.raise_if_interrupted();
        return to_python(out);
    }

private:
    // A group's axis: 0 for a board group (recorder, link, the matrices).
    uint8_t group_axis(link::ParamGroup g, const std::string& axis) {
        if (link::board_group(g) && axis.empty()) return 0;
        if (link::board_group(g)) throw std::invalid_argument("axis: " + std::string(link::group_name(g)) + " is the board's");
        return static_cast<uint8_t>(axis_of(axis));
    }
    json get_group(link::ParamGroup g, uint8_t axis) {
        json out;
        params::with_group(g, [&](auto tag) { out = hostlink::to_json(client().get<typename decltype(tag)::type>(axis)); });
        return out;
    }

    std::unique_ptr<Client> client_;
};

}  // namespace

void add_device(pyb::module_& m) {
    // `piezoloop devices`: the attached USB boards.
    m.def("devices", [] {
        json out;
        {
            pyb::gil_scoped_release release;
            out = cli::usb_boards_json();
        }
        return to_python(out);
    });
    pyb::class_<cli::WaveRequest>(m, "WaveRequest")
        .def(pyb::init<>())
        .def_readwrite("trajectory", &cli::WaveRequest::trajectory)
        .def_readwrite("frequency_Hz", &cli::WaveRequest::frequency_Hz)
        .def_readwrite("amplitude_um", &cli::WaveRequest::amplitude_um)
        .def_readwrite("offset", &cli::WaveRequest::offset)
        .def_readwrite("scenario", &cli::WaveRequest::scenario)
        .def_readwrite("cycles", &cli::WaveRequest::cycles);
    pyb::class_<Device>(m, "Device")
        .def(pyb::init<const std::string&, int>(), pyb::arg("address"), pyb::arg("timeout_ms"))
        .def("close", &Device::close)
        .def("address", [](Device& d) { return d.client().address(); })
        .def("status", &Device::status)
        .def("get", &Device::get)
        .def("set", &Device::set)
        .def("set_scenario", &Device::set_scenario)
        .def("arm", [](Device& d) { d.simple(&Client::arm); })
        .def("disarm", [](Device& d) { d.simple(&Client::disarm); })
        .def("clear_trip", [](Device& d) { d.simple(&Client::clear_trip); })
        .def("record", &Device::record)
        .def("save", [](Device& d) { d.simple(&Client::save); })
        .def("load", [](Device& d) { d.simple(&Client::load); })
        .def("forget", [](Device& d) { d.simple(&Client::forget); })
        .def("wave", &Device::wave)
        .def("stop", &Device::stop)
        .def("stream", &Device::stream)
        .def("measure_frf",
             [](Device& d, double from_Hz, double to_Hz, double amplitude_V, double bias_V, const std::string& mode,
                const std::string& signal, int periods, int transient_periods, bool restart_stage,
                const std::string& axis) {
                 return d.measure_frf(frf_request(from_Hz, to_Hz, amplitude_V, bias_V, mode, signal, periods,
                                                  transient_periods),
                                      restart_stage, axis);
             })
        .def("measure_step",
             [](Device& d, std::optional<double> step_um, std::optional<double> step_V, std::optional<double> from_um,
                std::optional<double> bias_V, const std::string& mode, double duration_s, bool restart_stage,
                const std::string& axis) {
                 return d.measure_step(step_options(step_um, step_V, from_um, bias_V, mode, duration_s), restart_stage,
                                       axis);
             })
        .def("measure_loops", &Device::measure_loops)
        .def("commission", &Device::commission)
        .def("measure_frf_mimo", &Device::measure_frf_mimo)
        .def("scan",
             [](Device& d, const std::string& scenario, const std::string& pattern, double size_x_um, double size_y_um,
                int pixels_x, int pixels_y, double line_rate_Hz, double retrace_speed, int frames,
                const std::string& sample, std::optional<std::pair<double, double>> centre_um, bool restart_stage,
                bool rc_period_from_scan) {
                 return d.scan(scan_request("", pattern, size_x_um, size_y_um, pixels_x, pixels_y, line_rate_Hz,
                                            retrace_speed, frames, sample, centre_um),
                               scenario, restart_stage, rc_period_from_scan);
             });
}

}  // namespace piezoloop::py
