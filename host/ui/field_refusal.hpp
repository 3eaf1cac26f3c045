// A request from one of the console's forms refused at the field it names,
// and the host's option names in a message ("--to-hz: must be ...")
// rewritten with the form's field names ("to_Hz: must be ..."), so a plan's
// refusal is shown at its field.
#pragma once

#include <span>
#include <stdexcept>
#include <string>
#include <utility>

namespace piezoloop::ui {

// "" for none in particular (shown below the form).
struct FieldRefusal : std::invalid_argument {
    FieldRefusal(std::string f, const std::string& message) : std::invalid_argument(message), field(std::move(f)) {}
    std::string field;
};

// {option, field} pairs; an option that is a suffix of another ("--periods",
// "--transient-periods") must come after it.
using OptionFields = std::span<const std::pair<const char*, const char*>>;

// The message with every option renamed, at the field of the option it
// starts with ("" when it starts with none).
FieldRefusal renamed_refusal(const std::string& message, OptionFields options);

}  // namespace piezoloop::ui
