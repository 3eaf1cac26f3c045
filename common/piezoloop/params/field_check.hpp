// Checks a parameter group against its declaration (params/groups.hpp):
// every number finite in float32 (the core's float type: a double that is
// finite but beyond float's range would reach the core as infinity) and
// within its declared range, every enum one of its names, every count within
// its array. The first failing field is reported with its path inside the
// group ("pi.thresholds", index 3; "sections[2].b0") and the allowed range,
// e.g. "must be in [0, 1000]". The board runs it on every SetParams, the
// host before it sends one, so both name the field the same way.
//
// The texts live in the FieldCheck object (the core cannot allocate): the
// Status it returns points into it and is valid while the object lives.
//
// first_critical_change() is the device's limit-critical policy: the first
// field declared limit-critical whose value differs between two sets.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "piezoloop/det_math.hpp"
#include "piezoloop/params/groups.hpp"
#include "piezoloop/params/text_buffer.hpp"
#include "piezoloop/status.hpp"

namespace piezoloop::params {

// Field path inside a group: "pid.u_min", "sections[2].b0".
class FieldPath {
public:
    constexpr void push(const char* name, int index = -1) {
        marks_[depth_ < kMaxDepth ? depth_ : kMaxDepth - 1] = text_.size();
        ++depth_;
        text_.append(name);
        if (index >= 0) {
            text_.append("[");
            text_.append_int(index);
            text_.append("]");
        }
        text_.append(".");
    }
    constexpr void pop() {
        if (depth_ == 0) return;
        --depth_;
        text_.truncate(marks_[depth_ < kMaxDepth ? depth_ : kMaxDepth - 1]);
    }
    // The path of a leaf, written into out.
    template <std::size_t N>
    constexpr void leaf(const char* name, TextBuffer<N>& out) const {
        out.clear();
        out.append(text_.c_str());
        out.append(name);
    }

private:
    static constexpr int kMaxDepth = 4;
    TextBuffer<32> text_{};
    std::array<std::size_t, kMaxDepth> marks_{};
    int depth_ = 0;
};

class FieldCheck {
public:
    template <class G>
    constexpr Status check(const G& g) {
        status_ = ok_status();
        path_ = FieldPath{};
        describe(*this, g);
        if (!status_.ok()) status_.group = group_name(G::kGroup);
        return status_;
    }

    // ---- visitor ----
    template <class X>
    constexpr void value(const Field& f, const X& x) {
        check_value(f, x, -1);
    }
    constexpr void begin(const char* name) { path_.push(name); }
    constexpr void end() { path_.pop(); }
    template <class C>
    constexpr void count(const Field& f, const C& n) {
        check_value(f, n, -1);
    }
    template <class X, std::size_t N, class C>
    constexpr void values(const Field& f, const std::array<X, N>& a, const C& n, Travel t) {
        const std::size_t m = checked(n, N, t);
        for (std::size_t i = 0; i < m; ++i) check_value(f, a[i], static_cast<int>(i));
    }
    template <class S, std::size_t N, class C>
    constexpr void objects(const char* name, const std::array<S, N>& a, const C& n, Travel t) {
        const std::size_t m = checked(n, N, t);
        for (std::size_t i = 0; i < m && status_.ok(); ++i) {
            path_.push(name, static_cast<int>(i));
            describe(*this, a[i]);
            path_.pop();
        }
    }

private:
    // Counted arrays: the elements in use; fixed layouts: all (they travel
    // and are stored, and a kind switched later would read them).
    template <class C>
    static constexpr std::size_t checked(const C& n, std::size_t capacity, Travel t) {
        if (t == Travel::kAll) return capacity;
        if constexpr (std::is_signed_v<C>)
            if (n < 0) return 0;
        return static_cast<std::size_t>(n) < capacity ? static_cast<std::size_t>(n) : capacity;
    }

    template <class X>
    constexpr void check_value(const Field& f, const X& x, int index) {
        if (!status_.ok()) return;
        double v = 0.0;
        if constexpr (std::is_enum_v<X>)
            v = static_cast<double>(static_cast<std::underlying_type_t<X>>(x));
        else
            v = static_cast<double>(x);
        if (f.wire == Wire::kBool) return;
        if (f.is_number() && !(is_finite(v) && v >= -kFloatMax && v <= kFloatMax)) {
            fail(f, index, f.wire == Wire::kF64 ? "must be finite in float32 (|x| <= 3.4028e+38)" : "must be finite");
            return;
        }
        const bool below = f.min_open ? !(v > f.min) : !(v >= f.min);
        const bool above = f.max_open ? !(v < f.max) : !(v <= f.max);
        if (!below && !above) return;
        message_.clear();
        if (f.is_enum()) {
            message_.append("must be one of ");
            for (uint8_t i = 0; i < f.name_count; ++i) {
                if (i > 0) message_.append(", ");
                message_.append(f.names[i]);
            }
        } else {
            message_.append("must be in ");
            message_.append(f.min_open ? "(" : "[");
            message_.append_number(f.min);
            message_.append(", ");
            message_.append_number(f.max);
            message_.append(f.max_open ? ")" : "]");
            if (f.unit[0] != '\0' && !(f.unit[0] == '1' && f.unit[1] == '\0')) {
                message_.append(" ");
                message_.append(f.unit);
            }
        }
        fail(f, index, message_.c_str());
    }

    constexpr void fail(const Field& f, int index, const char* message) {
        path_.leaf(f.name, field_);
        status_ = error(field_.c_str(), index, message);
    }

    Status status_{};
    FieldPath path_{};
    TextBuffer<32> field_{};     // the link's error reply carries 32 bytes of field
    TextBuffer<96> message_{};   // and 96 of message
};

// ---- limit-critical policy ---------------------------------------------------

// The limit-critical fields of a group, in declaration order.
class CriticalValues {
public:
    static constexpr std::size_t kMax = 8;

    template <class X>
    constexpr void value(const Field& f, const X& x) {
        if (!f.critical) return;
        if (n_ < kMax) {
            path_.leaf(f.name, names_[n_]);
            if constexpr (std::is_enum_v<X>)
                values_[n_] = static_cast<double>(static_cast<std::underlying_type_t<X>>(x));
            else
                values_[n_] = static_cast<double>(x);
        }
        ++n_;
    }
    constexpr void begin(const char* name) { path_.push(name); }
    constexpr void end() { path_.pop(); }
    template <class C>
    constexpr void count(const Field& f, const C& n) {
        value(f, n);
    }
    // Array elements are tuning values, never limit-critical.
    template <class X, std::size_t N, class C>
    constexpr void values(const Field&, const std::array<X, N>&, const C&, Travel) {}
    template <class S, std::size_t N, class C>
    constexpr void objects(const char*, const std::array<S, N>&, const C&, Travel) {}

    constexpr std::size_t size() const { return n_ < kMax ? n_ : kMax; }
    constexpr double value_at(std::size_t i) const { return values_[i]; }
    constexpr const char* name_at(std::size_t i) const { return names_[i].c_str(); }

private:
    FieldPath path_{};
    std::array<TextBuffer<32>, kMax> names_{};
    std::array<double, kMax> values_{};
    std::size_t n_ = 0;
};

// The path of the first limit-critical field that differs between `from`
// and `to` (written into out), or nullptr if none does. NaN differs from
// everything, so a NaN in a critical field is never "unchanged".
template <class G>
constexpr const char* first_critical_change(const G& from, const G& to, TextBuffer<32>& out) {
    CriticalValues a, b;
    describe(a, from);
    describe(b, to);
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (!(a.value_at(i) == b.value_at(i))) {
            out.clear();
            out.append(a.name_at(i));
            return out.c_str();
        }
    }
    return nullptr;
}

}  // namespace piezoloop::params
