// The QEMU boards' parameter storage: a host file, reached through ARM
// semihosting (QEMU runs with -semihosting), named on the semihosting
// command line as `--storage=PATH` (the rest of the line, so a path may
// hold spaces); `piezoloop emulate --storage FILE` passes it. Without that
// argument the board has no storage.
//
// The record is read into RAM and built in RAM, then written in one go: to
// PATH.new first, renamed over PATH, so an emulator stopped in the middle
// of a Save leaves the previous record, never half of one. A missing file
// is an empty storage; erase leaves an empty file.
//
// Semihosting operations ("Semihosting for AArch32 and AArch64", v2): each
// takes a block of 32-bit words in r1. The calls run in the main loop; under
// QEMU a call completes within one instruction of virtual time, so the tick
// is not delayed.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "bsp/bsp.hpp"
#include "bsp/cortex-m/semihosting.hpp"
#include "piezoloop/storage/param_storage.hpp"
#include "piezoloop/storage/stored_params.hpp"

namespace piezoloop::bsp {
namespace {

namespace sh {
inline constexpr uint32_t kOpen = 0x01;
inline constexpr uint32_t kClose = 0x02;
inline constexpr uint32_t kWrite = 0x05;
inline constexpr uint32_t kRead = 0x06;
inline constexpr uint32_t kFlen = 0x0C;
inline constexpr uint32_t kRename = 0x0F;
inline constexpr uint32_t kErrno = 0x13;
inline constexpr uint32_t kGetCmdline = 0x15;
// SYS_OPEN modes (the index of the fopen() mode string).
inline constexpr uint32_t kModeReadBinary = 1;   // "rb"
inline constexpr uint32_t kModeWriteBinary = 5;  // "wb"
inline constexpr uint32_t kFailed = 0xFFFFFFFFu;  // -1
inline constexpr uint32_t kEnoent = 2;  // the host's errno for a missing file (Linux, POSIX hosts)
}  // namespace sh

constexpr std::size_t kPathBytes = 256;  // with the terminating zero (the host refuses longer paths)
constexpr char kArgument[] = "--storage=";
constexpr char kNewSuffix[] = ".new";

// In .bss, outside the storage object: the object has a vtable pointer, so
// it is initialised data, and buffers inside it would take flash and a copy
// at start-up.
std::array<char, kPathBytes> g_path{};
std::array<char, kPathBytes> g_new_path{};
std::array<uint8_t, storage::kStoredParamsMaxBytes> g_image{};

uint32_t word(const void* p) { return static_cast<uint32_t>(reinterpret_cast<uintptr_t>(p)); }

std::size_t length(const char* s) {
    std::size_t n = 0;
    while (s[n] != '\0') ++n;
    return n;
}

uint32_t open_file(const char* path, uint32_t mode) {
    const uint32_t block[3] = {word(path), mode, static_cast<uint32_t>(length(path))};
    return semihosting::call(sh::kOpen, block);
}

void close_file(uint32_t handle) {
    const uint32_t block[1] = {handle};
    (void)semihosting::call(sh::kClose, block);
}

class SemihostingStorage final : public storage::ParamStorage {
public:
    // Takes the path from the semihosting command line; false if none.
    bool configure() {
        std::array<char, kPathBytes + sizeof kArgument + 64> line{};
        uint32_t block[2] = {word(line.data()), static_cast<uint32_t>(line.size() - 1)};
        if (semihosting::call(sh::kGetCmdline, block) != 0) return false;
        const char* at = find(line.data(), kArgument);
        if (at == nullptr) return false;
        at += sizeof kArgument - 1;
        const std::size_t n = length(at);
        if (n == 0 || n + sizeof kNewSuffix > kPathBytes) return false;
        for (std::size_t i = 0; i < n; ++i) {
            path_[i] = at[i];
            new_path_[i] = at[i];
        }
        for (std::size_t i = 0; i < sizeof kNewSuffix; ++i) new_path_[n + i] = kNewSuffix[i];
        return true;
    }

    Status read(std::span<const uint8_t>& out) override {
        out = {};
        const uint32_t h = open_file(path_.data(), sh::kModeReadBinary);
        if (h == sh::kFailed) {
            if (semihosting::call(sh::kErrno, nullptr) == sh::kEnoent) return ok_status();  // never saved
            return error("storage", "cannot open the storage file (semihosting SYS_OPEN)");
        }
        const uint32_t flen_block[1] = {h};
        const uint32_t size = semihosting::call(sh::kFlen, flen_block);
        if (size == sh::kFailed) {
            close_file(h);
            return error("storage", "cannot size the storage file (semihosting SYS_FLEN)");
        }
        // A longer file is read up to the largest record: its header's
        // length decides what belongs to the record.
        const uint32_t want = size < image_.size() ? size : static_cast<uint32_t>(image_.size());
        const uint32_t read_block[3] = {h, word(image_.data()), want};
        const uint32_t not_read = semihosting::call(sh::kRead, read_block);
        close_file(h);
        if (not_read > want) return error("storage", "cannot read the storage file (semihosting SYS_READ)");
        out = std::span<const uint8_t>(image_.data(), want - not_read);
        return ok_status();
    }

    std::span<uint8_t> scratch() override { return image_; }

    Status write(std::size_t bytes) override {
        if (bytes > image_.size()) return error("storage", "record larger than the storage image");
        if (const Status s = write_file(new_path_.data(), bytes); !s.ok()) return s;
        const uint32_t block[4] = {word(new_path_.data()), static_cast<uint32_t>(length(new_path_.data())),
                                   word(path_.data()), static_cast<uint32_t>(length(path_.data()))};
        if (semihosting::call(sh::kRename, block) != 0)
            return error("storage", "cannot replace the storage file (semihosting SYS_RENAME)");
        return ok_status();
    }

    Status erase() override { return write_file(path_.data(), 0); }

private:
    static const char* find(const char* text, const char* word) {
        const std::size_t n = length(word);
        for (; *text != '\0'; ++text) {
            std::size_t i = 0;
            while (i < n && text[i] == word[i]) ++i;
            if (i == n) return text;
        }
        return nullptr;
    }

    Status write_file(const char* path, std::size_t bytes) {
        const uint32_t h = open_file(path, sh::kModeWriteBinary);
        if (h == sh::kFailed) return error("storage", "cannot create the storage file (semihosting SYS_OPEN)");
        const uint32_t block[3] = {h, word(image_.data()), static_cast<uint32_t>(bytes)};
        const uint32_t not_written = bytes == 0 ? 0 : semihosting::call(sh::kWrite, block);
        close_file(h);
        if (not_written != 0) return error("storage", "cannot write the storage file (semihosting SYS_WRITE)");
        return ok_status();
    }

    std::array<char, kPathBytes>& path_ = g_path;
    std::array<char, kPathBytes>& new_path_ = g_new_path;
    std::array<uint8_t, storage::kStoredParamsMaxBytes>& image_ = g_image;
};

}  // namespace

storage::ParamStorage* param_storage() {
    static SemihostingStorage s;
    static bool configured = s.configure();
    return configured ? &s : nullptr;
}

}  // namespace piezoloop::bsp
