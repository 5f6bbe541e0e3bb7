// The prepared splats and mixes kept in memory (server/store/bounded_lru.h): at most so many and
// so many bytes, least recently used out first, never the last one.
#include "server/store/bounded_lru.h"

#include <gtest/gtest.h>

#include <string>

namespace textond::test {
namespace {

struct Kept {
    std::string id;
    std::size_t bytes = 0;
    int version = 0;
};

TEST(BoundedLru, TheLeastRecentGoesFirstPastTheCount) {
    store::BoundedLru<Kept> lru(3, 1000);
    lru.put({"a", 10});
    lru.put({"b", 10});
    lru.put({"c", 10});
    ASSERT_TRUE(lru.get("a")); // a is now the most recent: b is the least
    lru.put({"d", 10});
    EXPECT_FALSE(lru.get("b"));
    EXPECT_TRUE(lru.get("a") && lru.get("c") && lru.get("d"));
    EXPECT_EQ(lru.size(), 3u);
    EXPECT_EQ(lru.bytes(), 30u);
}

TEST(BoundedLru, TheLeastRecentGoesFirstPastTheBytes) {
    store::BoundedLru<Kept> lru(10, 100);
    lru.put({"a", 40});
    lru.put({"b", 40});
    ASSERT_TRUE(lru.get("a"));
    lru.put({"c", 40}); // 120 bytes: b, the least recent, out
    EXPECT_FALSE(lru.get("b"));
    EXPECT_TRUE(lru.get("a") && lru.get("c"));
    EXPECT_EQ(lru.bytes(), 80u);
}

TEST(BoundedLru, OneLargerThanTheBudgetIsStillKeptAlone) {
    store::BoundedLru<Kept> lru(3, 100);
    lru.put({"a", 10});
    lru.put({"big", 500});
    EXPECT_FALSE(lru.get("a"));
    ASSERT_TRUE(lru.get("big"));
    EXPECT_EQ(lru.size(), 1u);
    EXPECT_EQ(lru.bytes(), 500u);
}

TEST(BoundedLru, PutReplacesOneOfTheSameIdAndEraseForgets) {
    store::BoundedLru<Kept> lru(3, 100);
    lru.put({"a", 10, 1});
    lru.put({"a", 20, 2});
    EXPECT_EQ(lru.size(), 1u);
    EXPECT_EQ(lru.bytes(), 20u);
    EXPECT_EQ(lru.get("a")->version, 2);
    lru.erase("a");
    lru.erase("never kept");
    EXPECT_FALSE(lru.get("a"));
    EXPECT_EQ(lru.size(), 0u);
    EXPECT_EQ(lru.bytes(), 0u);
}

} // namespace
} // namespace textond::test
