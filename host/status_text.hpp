// Turns a core Status into the error text the host tools print:
// "<group>.<field>[<index>]: <message>"; and the board's status states in
// words: what became of the stored set, what a fault or a trip means.
#pragma once

#include <string>

#include "piezoloop/link/messages.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop {

inline std::string describe(const Status& s) {
    // Appended step by step: GCC 12 at -O3 reports a false -Wrestrict on
    // operator+ chains of std::string (GCC bug 105329).
    std::string text;
    if (s.group) {
        text += s.group;
        text += '.';
    }
    text += s.field ? s.field : "?";
    if (s.index >= 0) {
        text += '[';
        text += std::to_string(s.index);
        text += ']';
    }
    text += ": ";
    text += s.message ? s.message : "invalid";
    return text;
}

// What became of the board's stored parameter set at boot (StatusReply::storage).
inline const char* storage_state_text(link::StorageState s) {
    switch (s) {
        case link::StorageState::kAbsent: return "no storage on this board";
        case link::StorageState::kEmpty: return "nothing stored: booted with the safe default";
        case link::StorageState::kApplied: return "stored set applied at boot";
        case link::StorageState::kCorrupt: return "stored set ignored: corrupt; booted with the safe default";
        case link::StorageState::kOtherFirmware:
            return "stored set ignored: written by another firmware version; booted with the safe default";
        case link::StorageState::kRejected:
            return "stored set ignored: rejected by validation; booted with the safe default";
        case link::StorageState::kReadFailed:
            return "stored set ignored: the storage could not be read; booted with the safe default";
    }
    return "unknown storage state";
}

// What a fault of the status (by its name in the status JSON,
// docs/protocol.md, Status) means for the user; "" for a name not known.
inline const char* fault_meaning(const std::string& fault) {
    if (fault == "hard_limits_invalid") return "the board's hard limits are invalid: its output stays at zero";
    if (fault == "tick_overrun") return "a control tick ran past its period at least once";
    if (fault == "setpoint_underrun") return "a setpoint stream ran empty at least once (the setpoint held)";
    if (fault == "recorder_overrun") return "the recorder dropped frames the link could not carry";
    if (fault == "link_errors") return "the board received damaged frames on the link";
    if (fault == "client_lost") return "a client went silent and its wave or stream was stopped";
    if (fault == "board_faults") return "the board reports faults of its own (tick.board_faults)";
    return "";
}

// What a trip reason (by its name in the status JSON) means for the user.
inline const char* trip_meaning(const std::string& reason) {
    if (reason == "none") return "not tripped";
    if (reason == "not configured") return "no limits set yet: set the limits group before arming";
    if (reason == "invalid hard limits") return "the board's hard limits are invalid (permanent)";
    if (reason == "non-finite input") return "the controller produced NaN or infinity; output went to zero";
    if (reason == "sustained saturation") return "the output stayed at a limit longer than limits.saturation_trip_s";
    if (reason == "external") return "tripped from outside the limiter";
    return "";
}

}  // namespace piezoloop
