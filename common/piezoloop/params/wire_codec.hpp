// A parameter group's wire layout, from its declaration (params/groups.hpp),
// and so a link message's (link/messages.hpp):
// fields in declaration order, little-endian, no padding; an array travels
// as its count (declared before it) and then the first `count` elements, or
// all of its elements when the layout is fixed (Travel::kAll).
//
// The codec checks form only: a count beyond its array makes the body
// malformed (Reader::mark_bad), and reading stops there. Values go to the
// field check (params/field_check.hpp) unchanged.
#pragma once

#include <cstddef>
#include <type_traits>

#include "piezoloop/link/wire.hpp"
#include "piezoloop/params/groups.hpp"

namespace piezoloop::params {

template <class C>
constexpr bool is_negative(const C& n) {
    if constexpr (std::is_signed_v<C>) return n < 0; else return false;
}

class WireWriter {
public:
    constexpr explicit WireWriter(link::Writer& w) : w_(w) {}

    template <class X>
    constexpr void value(const Field& f, const X& x) {
        if constexpr (std::is_enum_v<X>) {
            put(f, static_cast<std::underlying_type_t<X>>(x));
        } else {
            put(f, x);
        }
    }
    constexpr void begin(const char*) {}
    constexpr void end() {}
    template <class C>
    constexpr void count(const Field& f, const C& n) {
        put(f, n);
    }
    template <class X, std::size_t N, class C>
    constexpr void values(const Field& f, const std::array<X, N>& a, const C& n, Travel t) {
        for (std::size_t i = 0; i < traveling(n, N, t); ++i) value(f, a[i]);
    }
    template <class S, std::size_t N, class C>
    constexpr void objects(const char*, const std::array<S, N>& a, const C& n, Travel t) {
        for (std::size_t i = 0; i < traveling(n, N, t); ++i) describe(*this, a[i]);
    }
    template <std::size_t N>
    constexpr void text(const Field&, const std::array<char, N>& a) {
        w_.text(a.data(), N);
    }

private:
    // A count beyond the array (only a corrupt struct has one) sends the array.
    template <class C>
    static constexpr std::size_t traveling(const C& n, std::size_t capacity, Travel t) {
        if (t == Travel::kAll) return capacity;
        if (is_negative(n)) return 0;
        return static_cast<std::size_t>(n) > capacity ? capacity : static_cast<std::size_t>(n);
    }
    template <class X>
    constexpr void put(const Field& f, const X& x) {
        switch (f.wire) {
            case Wire::kU8: w_.u8(static_cast<uint8_t>(x)); break;
            case Wire::kU16: w_.u16(static_cast<uint16_t>(x)); break;
            case Wire::kU32: w_.u32(static_cast<uint32_t>(x)); break;
            case Wire::kI16: w_.i16(static_cast<int16_t>(x)); break;
            case Wire::kI32: w_.i32(static_cast<int32_t>(x)); break;
            case Wire::kF32: w_.f32(static_cast<float>(x)); break;
            case Wire::kF64: w_.f64(static_cast<double>(x)); break;
            case Wire::kBool: w_.boolean(static_cast<bool>(x)); break;
        }
    }
    link::Writer& w_;
};

class WireReader {
public:
    constexpr explicit WireReader(link::Reader& r) : r_(r) {}

    template <class X>
    constexpr void value(const Field& f, X& x) {
        if (stopped_) return;
        if constexpr (std::is_enum_v<X>) {
            x = static_cast<X>(get<std::underlying_type_t<X>>(f));
        } else {
            x = get<X>(f);
        }
    }
    constexpr void begin(const char*) {}
    constexpr void end() {}
    template <class C>
    constexpr void count(const Field& f, C& n) {
        value(f, n);
    }
    template <class X, std::size_t N, class C>
    constexpr void values(const Field& f, std::array<X, N>& a, const C& n, Travel t) {
        const std::size_t m = traveling(n, N, t);
        for (std::size_t i = 0; i < m; ++i) value(f, a[i]);
        for (std::size_t i = m; i < N; ++i) a[i] = X{};  // one value per layout: unsent elements are zero
    }
    template <class S, std::size_t N, class C>
    constexpr void objects(const char*, std::array<S, N>& a, const C& n, Travel t) {
        const std::size_t m = traveling(n, N, t);
        for (std::size_t i = 0; i < m; ++i) describe(*this, a[i]);
        for (std::size_t i = m; i < N; ++i) a[i] = S{};
    }
    template <std::size_t N>
    constexpr void text(const Field&, std::array<char, N>& a) {
        if (stopped_) return;
        r_.text(a.data(), N, N);
    }

private:
    template <class C>
    constexpr std::size_t traveling(const C& n, std::size_t capacity, Travel t) {
        if (stopped_) return 0;
        if (is_negative(n) || static_cast<std::size_t>(n) > capacity) {
            r_.mark_bad();
            stopped_ = true;
            return 0;
        }
        return t == Travel::kAll ? capacity : static_cast<std::size_t>(n);
    }
    template <class X>
    constexpr X get(const Field& f) {
        switch (f.wire) {
            case Wire::kU8: return static_cast<X>(r_.u8());
            case Wire::kU16: return static_cast<X>(r_.u16());
            case Wire::kU32: return static_cast<X>(r_.u32());
            case Wire::kI16: return static_cast<X>(r_.i16());
            case Wire::kI32: return static_cast<X>(r_.i32());
            case Wire::kF32: return static_cast<X>(r_.f32());
            case Wire::kF64: return static_cast<X>(r_.f64());
            case Wire::kBool: return static_cast<X>(r_.boolean());
        }
        return X{};
    }
    link::Reader& r_;
    bool stopped_ = false;
};

template <class G>
constexpr void write_group(link::Writer& w, const G& g) {
    WireWriter v(w);
    describe(v, g);
}

template <class G>
constexpr void read_group(link::Reader& r, G& g) {
    WireReader v(r);
    describe(v, g);
}

// Bytes of a group's layout: `fixed`, plus per count field (at most four; a
// group has two at most) `per_element` bytes for each element it counts.
struct LayoutSize {
    struct Counted {
        const char* name = nullptr;  // the count field's
        std::size_t per_element = 0;
    };
    std::size_t fixed = 0;
    std::array<Counted, 4> counts{};
    int count_fields = 0;
    // Bytes per element when every count field counts the same.
    constexpr std::size_t per_count() const {
        std::size_t n = 0;
        for (int i = 0; i < count_fields; ++i) n += counts[static_cast<std::size_t>(i)].per_element;
        return n;
    }
};

class LayoutSizer {
public:
    template <class X>
    constexpr void value(const Field& f, const X&) {
        size_.fixed += wire_size(f.wire);
    }
    constexpr void begin(const char*) {}
    constexpr void end() {}
    template <class C>
    constexpr void count(const Field& f, const C&) {
        size_.fixed += wire_size(f.wire);
        if (size_.count_fields < static_cast<int>(size_.counts.size()))
            size_.counts[static_cast<std::size_t>(size_.count_fields++)].name = f.name;
    }
    template <class X, std::size_t N, class C>
    constexpr void values(const Field& f, const std::array<X, N>&, const C&, Travel t) {
        if (t == Travel::kAll)
            size_.fixed += N * wire_size(f.wire);
        else
            add_counted(wire_size(f.wire));
    }
    template <class S, std::size_t N, class C>
    constexpr void objects(const char*, const std::array<S, N>& a, const C&, Travel t) {
        const std::size_t before = size_.fixed;
        describe(*this, a[0]);
        const std::size_t one = size_.fixed - before;
        size_.fixed = before;
        if (t == Travel::kAll)
            size_.fixed += N * one;
        else
            add_counted(one);
    }
    template <std::size_t N>
    constexpr void text(const Field&, const std::array<char, N>&) {
        size_.fixed += N;
    }
    constexpr LayoutSize size() const { return size_; }

private:
    // Counted elements travel after their count field: to the latest one
    // (a message's array counted by a product of fields has none: "count").
    constexpr void add_counted(std::size_t bytes) {
        if (size_.count_fields == 0) size_.counts[static_cast<std::size_t>(size_.count_fields++)].name = "count";
        size_.counts[static_cast<std::size_t>(size_.count_fields - 1)].per_element += bytes;
    }
    LayoutSize size_{};
};

template <class G>
constexpr LayoutSize layout_size() {
    LayoutSizer s;
    const G g{};
    describe(s, g);
    return s.size();
}

}  // namespace piezoloop::params
