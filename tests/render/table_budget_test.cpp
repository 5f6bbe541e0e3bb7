// The budget of what prepared textons derive (render/table_budget.h): least recently used let go
// past it, what a caller holds kept alive, and a texton whose tables were let go renders the same
// bits from the tables it derives again.
#include "render/cpu_backend.h"
#include "render/table_budget.h"
#include "tests/render/render_fixtures.h"

#include <gtest/gtest.h>

#include <thread>
#include <vector>

using namespace textond;
using render::TableBudget;

namespace {

// The process's budget for one test, restored after.
struct BudgetOf {
    std::size_t before = TableBudget::instance().limit();
    explicit BudgetOf(std::size_t bytes) { TableBudget::instance().set_limit(bytes); }
    ~BudgetOf() { TableBudget::instance().set_limit(before); }
};

} // namespace

TEST(TableBudget, LetsTheLeastRecentlyUsedGoPastItsLimit) {
    const BudgetOf budget(100);
    auto a = std::make_shared<int>(1), b = std::make_shared<int>(2), c = std::make_shared<int>(3);
    const std::weak_ptr<int> wa = a, wb = b, wc = c;
    TableBudget::instance().use(a, 40);
    TableBudget::instance().use(b, 40);
    TableBudget::instance().use(a, 40); // a is the most recent now
    a.reset();
    b.reset();
    EXPECT_FALSE(wa.expired());
    EXPECT_FALSE(wb.expired());
    TableBudget::instance().use(c, 40); // 120 > 100: b, the least recent, goes
    EXPECT_TRUE(wb.expired());
    EXPECT_FALSE(wa.expired());
    EXPECT_LE(TableBudget::instance().bytes(), 100u);
    // What a caller holds outlives its place in the budget.
    auto big = std::make_shared<int>(4);
    TableBudget::instance().use(big, 1000); // over the limit alone: kept, everything else goes
    EXPECT_TRUE(wa.expired());
    EXPECT_EQ(TableBudget::instance().bytes(), 1000u);
    c.reset();
    EXPECT_TRUE(wc.expired());
    TableBudget::instance().use(std::make_shared<int>(5), 10);
    EXPECT_EQ(*big, 4);
}

TEST(TableBudget, ATextonRendersTheSameBitsFromTablesDerivedAgain) {
    const auto tex = test::analysed_texton("mypaint_HR_Cork.png", 32);
    render::CpuBackend cpu(2);
    auto tile = [&](int level) {
        render::NoiseRequest q;
        q.width = q.height = 64;
        q.level = level;
        q.x0 = 3;
        q.y0 = -5;
        q.seed = 7;
        return cpu.render(*tex, q).value();
    };
    std::vector<core::Image> first;
    for (int level = 0; level <= tex->limit_level() + 1; ++level) first.push_back(tile(level));
    const BudgetOf budget(1); // every table and covariance let go after its use
    for (int level = 0; level <= tex->limit_level() + 1; ++level) {
        SCOPED_TRACE(level);
        EXPECT_TRUE(tile(level).data == first[static_cast<std::size_t>(level)].data);
        EXPECT_LE(TableBudget::instance().bytes(),
                  std::size_t{8} << 20); // one table or covariance at most
    }
}

// A mix's tables of one level are one item: a tile reads every level's in turn, and a budget that
// let them go one by one had each gone before the next tile came back to it, so a mix larger than
// the budget built all its tables again for every tile.
TEST(TableBudget, AMixKeepsItsTablesOfALevelTogether) {
    core::MixField ramp;
    ramp.width = 64;
    const auto mix = test::analysed_mix("etr_sand01.png", "etr_pebbles04.png", 16, 4, ramp);
    const BudgetOf budget(1); // less than any one table
    auto serials = [&](int level) {
        std::vector<std::uint64_t> s;
        for (const auto& t : *mix->tables(level)) s.push_back(t->serial);
        return s;
    };
    const auto first = serials(3);
    ASSERT_EQ(first.size(), 4u);
    EXPECT_EQ(serials(3), first); // the set, the most recent item, stays whole
    (void)serials(2);             // another level's set takes its place
    EXPECT_NE(serials(3), first); // derived again, as one
}

// Concurrent tiles of a new level wait for one build of its table (each had built its own).
TEST(TableBudget, ATableIsBuiltOnceWhateverAsksAtOnce) {
    const auto tex = test::analysed_texton("etr_pebbles04.png", 64);
    std::vector<std::uint64_t> got(8);
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < got.size(); ++i)
        threads.emplace_back([&, i] { got[i] = tex->table(5)->serial; });
    for (auto& t : threads) t.join();
    for (auto s : got) EXPECT_EQ(s, got.front());
}
