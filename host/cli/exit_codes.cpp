#include "exit_codes.hpp"

#include <cmath>
#include <cstdlib>
#include <iostream>

#include "link/transport.hpp"
#include "options/option_checks.hpp"

namespace piezoloop::cli {

int exit_code_of(const std::exception& e) {
    if (dynamic_cast<const std::invalid_argument*>(&e)) return kExitBadInput;
    if (dynamic_cast<const hostlink::LinkError*>(&e)) return kExitLinkOrDevice;
    if (dynamic_cast<const LostData*>(&e)) return kExitLostData;
    return kExitFailure;
}

int report_failure(const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return exit_code_of(e);
}

int run_app(CLI::App& app, int argc, char** argv) {
    try {
        app.parse(argc, argv);
    } catch (const CLI::RuntimeError& e) {
        return e.get_exit_code();  // the command printed its own message
    } catch (const CLI::ParseError& e) {
        // Help and version requests (exit code 0) and option errors, whose
        // CLI11 codes (104-106, ...) all mean bad input.
        const int rc = app.exit(e);
        return rc == 0 ? kExitOk : kExitBadInput;
    } catch (const std::exception& e) {
        return report_failure(e);
    }
    return kExitOk;
}

namespace {

// The text of a FLOAT option's value is finite (CLI11's own checks, such as
// Range, let "nan" through: every comparison with NaN is false).
std::string finite_or_message(const std::string& text) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end != text.c_str() && !std::isfinite(v)) return "must be a finite number (got " + text + ")";
    return {};
}

}  // namespace

void require_finite_numbers(CLI::App& app) {
    static const CLI::Validator finite(finite_or_message, "", "FINITE");
    for (CLI::Option* opt : app.get_options()) {
        // Type names of double, float and their vectors and optionals.
        if (opt->get_type_name().rfind("FLOAT", 0) == 0) opt->check(finite);
    }
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) require_finite_numbers(*sub);
}

template <class T>
CLI::Option* add_number_list(CLI::App* cmd, const std::string& name, std::vector<T>& out, const std::string& help) {
    return cmd
        ->add_option_function<std::string>(
            name, [&out, name](const std::string& text) { out = options::parse_number_list<T>(name, text); }, help)
        ->type_name("LIST");
}

template CLI::Option* add_number_list<double>(CLI::App*, const std::string&, std::vector<double>&, const std::string&);
template CLI::Option* add_number_list<float>(CLI::App*, const std::string&, std::vector<float>&, const std::string&);

}  // namespace piezoloop::cli
