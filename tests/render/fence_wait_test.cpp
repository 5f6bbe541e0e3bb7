// The GL backends' fence wait (render/gl/fence_wait.h) on a fake clock: it sleeps through a
// pass instead of asking the driver (which spins) without end, and answers within a step of the
// pass's end.
#include "render/gl/fence_wait.h"

#include <gtest/gtest.h>

#include <algorithm>

using namespace textond::render::gl;
using std::chrono::microseconds;

namespace {

// A pass that ends `lasts` after the wait starts; the clock moves only by the wait's sleeps.
struct FakePass {
    microseconds lasts;
    microseconds now{0};
    bool fails = false;
    FenceWait wait(microseconds expected) {
        return await_fence(
            [this] {
                if (fails) return FenceState::failed;
                return now >= lasts ? FenceState::signalled : FenceState::pending;
            },
            expected, [this](microseconds d) { now += d; });
    }
};

} // namespace

TEST(FenceWait, ADoneFenceIsAskedOnceAndNeverSleptOn) {
    FakePass pass{microseconds{0}};
    const FenceWait w = pass.wait(microseconds{5000});
    EXPECT_EQ(w.state, FenceState::signalled);
    EXPECT_EQ(w.polls, 1);
    EXPECT_EQ(w.slept.count(), 0);
}

TEST(FenceWait, APassThatEndsAsEstimatedIsSleptThroughAndAnsweredWithinAStep) {
    for (long long us : {200LL, 6000LL, 40000LL}) {
        FakePass pass{microseconds{us}};
        const FenceWait w = pass.wait(microseconds{us});
        EXPECT_EQ(w.state, FenceState::signalled);
        EXPECT_GE(w.slept.count(), us);
        // Within a step of its end: a twentieth of the estimate (50 us at least), grown a little.
        EXPECT_LE(w.slept.count() - us, std::max(100LL, us / 10)) << us;
        // Three quarters slept at once, then the last quarter in steps of at most 1 ms.
        const long long step = std::min(1000LL, std::max(50LL, us / 20));
        EXPECT_LE(w.polls, 2 + us / 4 / step) << us;
    }
}

TEST(FenceWait, APassFarLongerThanEstimatedIsAskedAboutAThousandTimesASecond) {
    FakePass pass{microseconds{1000000}};
    const FenceWait w = pass.wait(microseconds{1000});
    EXPECT_EQ(w.state, FenceState::signalled);
    EXPECT_GE(w.slept.count(), 1000000);
    EXPECT_LE(w.slept.count() - 1000000, 1000); // steps stop growing at 1 ms
    EXPECT_LE(w.polls, 1100);
    EXPECT_GE(w.polls, 900);
}

TEST(FenceWait, WithoutAnEstimateItStepsFrom50Microseconds) {
    FakePass pass{microseconds{3000}};
    const FenceWait w = pass.wait(microseconds{-200}); // past its estimate already
    EXPECT_EQ(w.state, FenceState::signalled);
    EXPECT_GE(w.slept.count(), 3000);
    EXPECT_LE(w.polls, 20);
}

TEST(FenceWait, AFailedFenceEndsTheWait) {
    FakePass pass{microseconds{1000000}};
    pass.fails = true;
    const FenceWait w = pass.wait(microseconds{1000});
    EXPECT_EQ(w.state, FenceState::failed);
    EXPECT_EQ(w.polls, 1);
}

TEST(FenceWait, APassIsEstimatedFromTheCheapestRecentPass) {
    PassTimeEstimate e;
    EXPECT_EQ(e.of(1000000).count(), 0); // nothing measured: no estimate
    e.measured(2.0, 1000000);            // 2 ns a pixel
    EXPECT_EQ(e.of(500000).count(), 1000);
    e.measured(0.0, 1000); // no time (a software renderer's or a failed query): ignored
    e.measured(1.0, 0);
    EXPECT_EQ(e.of(500000).count(), 1000);
    e.measured(60.0, 1000000); // an expensive pass: a cheap one must not sleep through it
    EXPECT_EQ(e.of(1000000).count(), 2000);
    for (int i = 0; i < 15; ++i) e.measured(6.0, 1000000); // the 2 ns pass is 16 passes old
    EXPECT_EQ(e.of(1000000).count(), 6000);
}
