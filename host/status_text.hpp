// Turns a core Status into the error text the host tools print:
// "<group>.<field>[<index>]: <message>"; and the board's status states in
// words.
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

}  // namespace piezoloop
