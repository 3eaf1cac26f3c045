// The STM32H743's parameter storage: the last sector of flash bank 2
// (sector 7, 0x081E0000, 128 KiB), which memory.ld leaves out of the image.
// The record (common/piezoloop/storage/stored_params.hpp) is read where it
// lies (flash is memory-mapped; the D-cache is off, bsp board.cpp) and
// written by erasing the sector and programming it 256-bit word by word.
// Written from RM0433 rev 8, §4.3 (embedded flash memory: §4.3.7 flash word,
// §4.3.9 programming, §4.3.10 sector erase), §4.5.1 (unlocking FLASH_CRx)
// and §4.9 (registers); the register names are in regs.hpp.
//
// NOT VERIFIED ON HARDWARE HERE (no board, and QEMU has no model of this
// part): it builds and links in the fw-stm32h743 preset only.
//
// While bank 2 is erased or programmed, bank 1 -- where the image and its
// interrupt handlers run -- stays readable (§4.3.3, read-while-write between
// banks), so the tick runs on; the main loop waits for the operation (a
// sector erase takes up to seconds), which is why the link refuses Save and
// Forget while armed. A reset in the middle of a Save leaves an erased
// sector (empty at boot) or a record whose CRC fails (ignored at boot).
// Not handled: a reset within the programming of one flash word can leave
// that word with an ECC double error, and reading it then ends in a bus
// fault at boot; erase the sector with a debugger (or STM32CubeProgrammer).
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "bsp/bsp.hpp"
#include "bsp/stm32h743/dcache.hpp"
#include "bsp/stm32h743/regs.hpp"
#include "piezoloop/storage/param_storage.hpp"
#include "piezoloop/storage/stored_params.hpp"

namespace piezoloop::bsp {
namespace {

using stm32::reg;
namespace fl = stm32::flash;

constexpr uint32_t kSector = 7;  // the last of bank 2
constexpr uintptr_t kSectorAddress = fl::kBank2 + kSector * fl::kSectorBytes;
// The record rounded up to whole flash words.
constexpr std::size_t kImageBytes =
    (storage::kStoredParamsMaxBytes + fl::kWordBytes - 1) / fl::kWordBytes * fl::kWordBytes;
static_assert(kImageBytes <= fl::kSectorBytes);
// Polls of SR2 before an operation counts as hung: well beyond the longest
// sector erase (a few seconds) at 480 MHz.
constexpr uint32_t kMaxPolls = 1'000'000'000u;

// Where a record is built before programming. In .bss, outside the storage
// object: the object has a vtable pointer, so it is initialised data, and a
// buffer inside it would take flash and a copy at start-up.
alignas(4) std::array<uint8_t, kImageBytes> g_image{};

class FlashStorage final : public storage::ParamStorage {
public:
    Status read(std::span<const uint8_t>& out) override {
        out = std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(kSectorAddress), kImageBytes);
        return ok_status();
    }

    std::span<uint8_t> scratch() override { return std::span<uint8_t>(image_.data(), storage::kStoredParamsMaxBytes); }

    Status write(std::size_t bytes) override {
        if (bytes > storage::kStoredParamsMaxBytes) return error("storage", "record larger than the flash image");
        // The last word's unused bytes as erased flash.
        const std::size_t padded = (bytes + fl::kWordBytes - 1) / fl::kWordBytes * fl::kWordBytes;
        for (std::size_t i = bytes; i < padded; ++i) image_[i] = 0xFF;
        if (const Status s = erase(); !s.ok()) return s;
        unlock();
        const Status s = program(padded);
        lock();
        forget_cached();
        if (!s.ok()) return s;
        const auto* stored = reinterpret_cast<const volatile uint8_t*>(kSectorAddress);
        for (std::size_t i = 0; i < bytes; ++i)
            if (stored[i] != image_[i]) return error("storage", "flash read back differs from what was programmed");
        return ok_status();
    }

    Status erase() override {
        unlock();
        Status s = wait_idle();
        if (s.ok()) {
            // §4.3.10: SER with the sector number, then START.
            reg(fl::kCr2) = (reg(fl::kCr2) & ~fl::kCrSnbMask) | fl::kCrSer | fl::kCrPsizeX64 | (kSector << fl::kCrSnbShift);
            reg(fl::kCr2) = reg(fl::kCr2) | fl::kCrStart;
            s = wait_done("flash sector erase failed (FLASH_SR2 error flag)");
            reg(fl::kCr2) = reg(fl::kCr2) & ~(fl::kCrSer | fl::kCrSnbMask);
        }
        lock();
        forget_cached();
        return s;
    }

private:
    // §4.5.1: the two keys in order; a wrong sequence locks FLASH_CR2 until reset.
    static void unlock() {
        if ((reg(fl::kCr2) & fl::kCrLock) == 0) return;
        reg(fl::kKeyr2) = fl::kKey1;
        reg(fl::kKeyr2) = fl::kKey2;
    }
    static void lock() { reg(fl::kCr2) = reg(fl::kCr2) | fl::kCrLock; }
    // The sector changed behind the data cache (on in the three-axis image,
    // dcache.hpp): its next read comes from the flash.
    static void forget_cached() { stm32::dcache_invalidate(kSectorAddress, kImageBytes); }

    // Nothing in progress, earlier error flags cleared.
    static Status wait_idle() {
        for (uint32_t i = 0; (reg(fl::kSr2) & (fl::kSrBsy | fl::kSrQw | fl::kSrWbne)) != 0; ++i)
            if (i == kMaxPolls) return error("storage", "flash bank 2 stays busy");
        reg(fl::kCcr2) = fl::kSrErrors | fl::kSrEop;
        return ok_status();
    }

    // The queued operation finished (QW and BSY clear) without an error flag.
    static Status wait_done(const char* failure) {
        for (uint32_t i = 0; (reg(fl::kSr2) & (fl::kSrBsy | fl::kSrQw)) != 0; ++i)
            if (i == kMaxPolls) return error("storage", "flash operation did not finish");
        const uint32_t errors = reg(fl::kSr2) & fl::kSrErrors;
        reg(fl::kCcr2) = fl::kSrErrors | fl::kSrEop;
        return errors == 0 ? ok_status() : error("storage", failure);
    }

    // §4.3.9: with PG set, eight 32-bit writes fill the write buffer of one
    // flash word, which is then programmed; wait for it before the next.
    Status program(std::size_t bytes) {
        if (const Status s = wait_idle(); !s.ok()) return s;
        reg(fl::kCr2) = reg(fl::kCr2) | fl::kCrPg | fl::kCrPsizeX64;
        Status s = ok_status();
        for (std::size_t at = 0; at < bytes && s.ok(); at += fl::kWordBytes) {
            auto* dst = reinterpret_cast<volatile uint32_t*>(kSectorAddress + at);
            for (std::size_t w = 0; w < fl::kWordBytes / 4; ++w) {
                const std::size_t b = at + 4 * w;
                dst[w] = uint32_t{image_[b]} | uint32_t{image_[b + 1]} << 8 | uint32_t{image_[b + 2]} << 16 |
                         uint32_t{image_[b + 3]} << 24;
            }
            asm volatile("dsb" ::: "memory");  // the word's writes reach the flash interface before polling
            s = wait_done("flash programming failed (FLASH_SR2 error flag)");
        }
        reg(fl::kCr2) = reg(fl::kCr2) & ~fl::kCrPg;
        return s;
    }

    std::array<uint8_t, kImageBytes>& image_ = g_image;
};

}  // namespace

storage::ParamStorage* param_storage() {
    static FlashStorage s;
    return &s;
}

}  // namespace piezoloop::bsp
