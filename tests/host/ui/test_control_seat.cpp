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

// Taking the seat over: the holder is asked; it gives the seat, keeps it,
// or does not answer within kAnswerTimeout and the seat passes.
TEST(UiControlSeat, AWatcherAsksTheHolderGivesKeepsOrTimesOut) {
    ControlSeat seat;
    const std::string a = seat.join(), b = seat.join(), c = seat.join();
    const auto t0 = ControlSeat::Clock::now();
    EXPECT_EQ(seat.ask(a, t0), ControlSeat::Asked::kTaken);  // free: taken at once
    uint64_t serial = seat.serial();
    EXPECT_EQ(seat.ask(b, t0), ControlSeat::Asked::kAsked);
    EXPECT_GT(seat.serial(), serial);
    ASSERT_TRUE(seat.request());
    EXPECT_EQ(seat.request()->from, b);
    EXPECT_EQ(seat.ask(c, t0), ControlSeat::Asked::kRefused);  // one request at a time
    EXPECT_FALSE(seat.answer(b, true));                       // only the holder answers
    EXPECT_TRUE(seat.answer(a, false));                       // kept
    EXPECT_TRUE(seat.holds(a));
    EXPECT_TRUE(seat.was_refused(b));
    EXPECT_FALSE(seat.request());
    EXPECT_FALSE(seat.answer(a, true));  // nothing pending

    EXPECT_EQ(seat.ask(b, t0), ControlSeat::Asked::kAsked);  // again
    EXPECT_FALSE(seat.was_refused(b));
    EXPECT_TRUE(seat.answer(a, true));  // given
    EXPECT_TRUE(seat.holds(b));
    EXPECT_FALSE(seat.holds(a));

    // No answer: the seat passes at the deadline, not before.
    const auto t1 = t0 + std::chrono::seconds(100);
    EXPECT_EQ(seat.ask(c, t1), ControlSeat::Asked::kAsked);
    EXPECT_FALSE(seat.expire(t1 + ControlSeat::kAnswerTimeout - std::chrono::milliseconds(1)));
    EXPECT_TRUE(seat.holds(b));
    EXPECT_TRUE(seat.expire(t1 + ControlSeat::kAnswerTimeout));
    EXPECT_TRUE(seat.holds(c));
    EXPECT_FALSE(seat.expire(t1 + 2 * ControlSeat::kAnswerTimeout));  // nothing pending
}

TEST(UiControlSeat, AHolderLeavingOrReleasingLeavesTheSeatToTheAsker) {
    ControlSeat seat;
    const std::string a = seat.join(), b = seat.join(), c = seat.join();
    const auto t0 = ControlSeat::Clock::now();
    ASSERT_TRUE(seat.claim(a));
    ASSERT_EQ(seat.ask(b, t0), ControlSeat::Asked::kAsked);
    seat.leave(a);
    EXPECT_TRUE(seat.holds(b));
    ASSERT_EQ(seat.ask(c, t0), ControlSeat::Asked::kAsked);
    seat.release(b);
    EXPECT_TRUE(seat.holds(c));
    // An asker that leaves withdraws its request.
    ASSERT_EQ(seat.ask(b, t0), ControlSeat::Asked::kAsked);
    seat.leave(b);
    EXPECT_FALSE(seat.request());
    EXPECT_FALSE(seat.expire(t0 + 2 * ControlSeat::kAnswerTimeout));
    EXPECT_TRUE(seat.holds(c));
    EXPECT_EQ(seat.ask("not-a-viewer", t0), ControlSeat::Asked::kRefused);
}

}  // namespace
}  // namespace piezoloop::ui
