// One controlling page at a time (host/ui/control_seat).
#include <gtest/gtest.h>

#include "ui/control_seat.hpp"

namespace piezoloop::ui {
namespace {

TEST(UiControlSeat, OnePageControlsTheOthersWatch) {
    ControlSeat seat;
    const std::string a = seat.join(), b = seat.join();
    EXPECT_NE(a, b);
    EXPECT_FALSE(seat.holder());
    EXPECT_TRUE(seat.claim(a));
    EXPECT_TRUE(seat.claim(a));  // again: still its own
    EXPECT_FALSE(seat.claim(b));
    EXPECT_TRUE(seat.holds(a));
    EXPECT_FALSE(seat.holds(b));
    seat.release(b);  // not b's to release
    EXPECT_TRUE(seat.holds(a));
    seat.release(a);
    EXPECT_TRUE(seat.claim(b));
    EXPECT_FALSE(seat.claim(a));
}

TEST(UiControlSeat, TheSeatFreesWhenItsHolderLeaves) {
    ControlSeat seat;
    const std::string a = seat.join(), b = seat.join();
    ASSERT_TRUE(seat.claim(a));
    seat.leave(a);
    EXPECT_FALSE(seat.holder());
    EXPECT_FALSE(seat.claim(a));  // gone: an unknown viewer claims nothing
    EXPECT_TRUE(seat.claim(b));
    EXPECT_FALSE(seat.claim("not-a-viewer"));
    EXPECT_EQ(seat.viewers(), 1u);
}

}  // namespace
}  // namespace piezoloop::ui
