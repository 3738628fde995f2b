#include <random>

#include <gtest/gtest.h>
#include <Eigen/Core>

#include "common/time/timed_channel.hpp"

namespace fieldline {
namespace timed_channel_test {

constexpr Utime kNow = 10'000'000;

TEST(TimedChannel, KeepsSamplesOrderedAndFindsByBinarySearch) {
  TimedChannel<double> ch({.capacity = 10});
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(ch.insert(1000 * i, i * 2.0, kNow), InsertResult::kAccepted);
  }
  EXPECT_EQ(ch.size(), 5u);
  EXPECT_EQ(ch.indexAtOrAfter(0), 0u);
  EXPECT_EQ(ch.indexAtOrAfter(1), 1u);
  EXPECT_EQ(ch.indexAtOrAfter(2000), 2u);
  EXPECT_EQ(ch.indexAtOrAfter(4001), 5u);
  EXPECT_EQ(ch.oldest().utime, 0);
  EXPECT_EQ(ch.newest().utime, 4000);
}

TEST(TimedChannel, InterpolatesBetweenNeighboursAndNotOutside) {
  TimedChannel<double> ch;
  ch.insert(1000, 10.0, kNow);
  ch.insert(2000, 20.0, kNow);
  ch.insert(4000, 0.0, kNow);
  EXPECT_DOUBLE_EQ(*ch.at(1500), 15.0);
  EXPECT_DOUBLE_EQ(*ch.at(2000), 20.0);
  EXPECT_DOUBLE_EQ(*ch.at(3000), 10.0);
  EXPECT_DOUBLE_EQ(*ch.at(1000), 10.0);
  EXPECT_FALSE(ch.at(999).has_value());
  EXPECT_FALSE(ch.at(4001).has_value());
  const auto b = ch.around(2500);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->before->utime, 2000);
  EXPECT_EQ(b->after->utime, 4000);
}

TEST(TimedChannel, InterpolatesEigenVectors) {
  TimedChannel<Eigen::Vector2d> ch;
  ch.insert(0 + 1, Eigen::Vector2d(0, 0), kNow);
  ch.insert(100 + 1, Eigen::Vector2d(1, -2), kNow);
  const auto v = ch.at(26);
  ASSERT_TRUE(v);
  EXPECT_NEAR((*v - Eigen::Vector2d(0.25, -0.5)).norm(), 0.0, 1e-12);
}

TEST(TimedChannel, NearestPicksTheCloserSample) {
  TimedChannel<int> ch;
  ch.insert(100, 1, kNow);
  ch.insert(200, 2, kNow);
  EXPECT_EQ(ch.nearest(0)->value, 1);
  EXPECT_EQ(ch.nearest(149)->value, 1);
  EXPECT_EQ(ch.nearest(151)->value, 2);
  EXPECT_EQ(ch.nearest(1000)->value, 2);
}

TEST(TimedChannel, CapacityEvictsOldest) {
  TimedChannel<int> ch({.capacity = 3});
  for (int i = 1; i <= 5; ++i)
    ch.insert(i * 10, i, kNow);
  EXPECT_EQ(ch.size(), 3u);
  EXPECT_EQ(ch.oldest().utime, 30);
  EXPECT_EQ(ch.counters().evicted, 2u);
  EXPECT_EQ(ch.counters().accepted, 5u);
}

TEST(TimedChannel, RejectsOutOfOrderAndDuplicateByDefault) {
  TimedChannel<int> ch;
  ch.insert(100, 1, kNow);
  ch.insert(200, 2, kNow);
  EXPECT_EQ(ch.insert(150, 3, kNow), InsertResult::kOutOfOrder);
  EXPECT_EQ(ch.insert(200, 3, kNow), InsertResult::kDuplicate);
  EXPECT_EQ(ch.size(), 2u);
  EXPECT_EQ(ch.counters().out_of_order, 1u);
  EXPECT_EQ(ch.counters().duplicate, 1u);
}

TEST(TimedChannel, InsertsLateSamplesInPlaceWhenAllowed) {
  TimedChannel<int> ch({.capacity = 4, .insert_late = true});
  ch.insert(100, 1, kNow);
  ch.insert(300, 3, kNow);
  EXPECT_EQ(ch.insert(200, 2, kNow), InsertResult::kAccepted);
  ASSERT_EQ(ch.size(), 3u);
  EXPECT_EQ(ch[1].value, 2);
  ch.insert(400, 4, kNow);
  // Full: a sample older than everything kept is too old, one inside the history replaces the
  // oldest.
  EXPECT_EQ(ch.insert(50, 0, kNow), InsertResult::kTooOld);
  EXPECT_EQ(ch.insert(250, 5, kNow), InsertResult::kAccepted);
  EXPECT_EQ(ch.oldest().utime, 200);
  for (std::size_t i = 1; i < ch.size(); ++i)
    EXPECT_LT(ch[i - 1].utime, ch[i].utime);
}

TEST(TimedChannel, RejectsTooOld) {
  TimedChannel<int> ch({.capacity = 100, .max_age_us = 1000, .insert_late = true});
  ch.insert(5000, 1, kNow);
  EXPECT_EQ(ch.insert(3999, 2, kNow), InsertResult::kTooOld);
  EXPECT_EQ(ch.insert(4000, 2, kNow), InsertResult::kAccepted);
  EXPECT_EQ(ch.counters().too_old, 1u);
}

TEST(TimedChannel, RejectsFromTheFuture) {
  TimedChannel<int> ch({.future_tolerance_us = 100});
  EXPECT_EQ(ch.insert(kNow + 101, 1, kNow), InsertResult::kFromFuture);
  EXPECT_EQ(ch.insert(kNow + 100, 1, kNow), InsertResult::kAccepted);
  EXPECT_EQ(ch.counters().from_future, 1u);
  EXPECT_EQ(ch.size(), 1u);
}

TEST(TimedChannel, RandomLateInsertsStaySortedAndMatchReference) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<Utime> jitter(-5000, 5000);
  TimedChannel<Utime> ch({.capacity = 64, .insert_late = true});
  std::vector<Utime> kept;
  for (int i = 0; i < 2000; ++i) {
    const Utime t = 10'000 + i * 1000 + jitter(rng);
    if (ch.insert(t, t, kNow) == InsertResult::kAccepted) kept.push_back(t);
  }
  for (std::size_t i = 1; i < ch.size(); ++i)
    ASSERT_LT(ch[i - 1].utime, ch[i].utime);
  for (std::size_t i = 0; i < ch.size(); ++i)
    ASSERT_EQ(ch[i].value, ch[i].utime);
  std::sort(kept.begin(), kept.end());
  // The channel holds exactly the `size()` latest of all accepted samples, in order.
  ASSERT_EQ(ch.size(), 64u);
  EXPECT_EQ(ch.counters().accepted, kept.size());
  for (std::size_t i = 0; i < ch.size(); ++i) {
    ASSERT_EQ(ch[i].utime, kept[kept.size() - ch.size() + i]) << i;
  }
}

TEST(TimedChannel, DropBefore) {
  TimedChannel<int> ch;
  for (int i = 1; i <= 5; ++i)
    ch.insert(i * 10, i, kNow);
  ch.dropBefore(30);
  EXPECT_EQ(ch.size(), 3u);
  EXPECT_EQ(ch.oldest().utime, 30);
}

}  // namespace timed_channel_test
}  // namespace fieldline
