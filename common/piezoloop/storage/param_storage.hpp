// Where a board keeps its parameter record (storage/stored_params.hpp): the
// interface the link device (link/device.hpp) uses for Save, Load, Forget
// and the load at boot. Backends: memory_storage.hpp (host, tests), a host
// file through semihosting (QEMU boards, firmware/bsp/mps2/), a flash
// sector (STM32H743, firmware/bsp/stm32h743/).
//
// Main-loop context only: a backend may block for as long as its medium
// takes (a flash sector erase takes up to seconds), never in the tick.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "piezoloop/status.hpp"

namespace piezoloop::storage {

class ParamStorage {
public:
    // The stored bytes in `out` (empty: nothing stored), valid until the
    // next write() or erase(). An error only when the medium cannot be read.
    virtual Status read(std::span<const uint8_t>& out) = 0;
    // Where the caller builds a record before write(): at least
    // kStoredParamsMaxBytes bytes.
    virtual std::span<uint8_t> scratch() = 0;
    // Replaces what is stored with the first `bytes` bytes of scratch().
    virtual Status write(std::size_t bytes) = 0;
    // Leaves the storage empty.
    virtual Status erase() = 0;

protected:
    // Never deleted through this interface (the firmware has no heap).
    ~ParamStorage() = default;
};

}  // namespace piezoloop::storage
