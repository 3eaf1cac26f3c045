// Result of configuring or validating something: either ok, or the name of the
// offending field and a message that states the allowed range. Messages are
// string literals so a Status can be returned from the tick-free configure
// paths on the target without any allocation.
#pragma once

namespace piezoloop {

struct Status {
    const char* field = nullptr;    // null means ok
    const char* message = nullptr;  // what is allowed, e.g. "must be in (0, 1]"
    int index = -1;                 // element of an array field, -1 if none
    const char* group = nullptr;    // parameter group (e.g. "pi", "rc") when nested
    constexpr bool ok() const { return field == nullptr; }
};

constexpr Status ok_status() { return {}; }
constexpr Status error(const char* field, const char* message) { return {field, message, -1}; }
constexpr Status error(const char* field, int index, const char* message) {
    return {field, message, index};
}

// The same error, reported as part of a parameter group.
constexpr Status in_group(const char* group, Status s) {
    if (!s.ok()) s.group = group;
    return s;
}

}  // namespace piezoloop
