// A parameter storage in memory (host tests, the Python bindings): what is
// stored lives as long as the object. Tests reach the stored bytes to
// corrupt them, and can make the medium fail.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "piezoloop/storage/param_storage.hpp"
#include "piezoloop/storage/stored_params.hpp"

namespace piezoloop::storage {

class MemoryStorage final : public ParamStorage {
public:
    Status read(std::span<const uint8_t>& out) override {
        if (fail_) return error("storage", "memory storage set to fail");
        out = std::span<const uint8_t>(stored_.data(), size_);
        return ok_status();
    }
    std::span<uint8_t> scratch() override { return scratch_; }
    Status write(std::size_t bytes) override {
        if (fail_) return error("storage", "memory storage set to fail");
        if (bytes > scratch_.size()) return error("storage", "record larger than the storage");
        stored_ = scratch_;
        size_ = bytes;
        ++writes_;
        return ok_status();
    }
    Status erase() override {
        if (fail_) return error("storage", "memory storage set to fail");
        size_ = 0;
        return ok_status();
    }

    // For tests: the stored bytes (to corrupt them), its size, a failing medium.
    std::span<uint8_t> stored() { return std::span<uint8_t>(stored_.data(), size_); }
    void set_size(std::size_t n) { size_ = n <= stored_.size() ? n : stored_.size(); }
    void set_fail(bool f) { fail_ = f; }
    int writes() const { return writes_; }

private:
    std::array<uint8_t, kStoredParamsMaxBytes> stored_{};
    std::array<uint8_t, kStoredParamsMaxBytes> scratch_{};
    std::size_t size_ = 0;
    bool fail_ = false;
    int writes_ = 0;
};

}  // namespace piezoloop::storage
