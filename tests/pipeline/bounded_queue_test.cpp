// Tests for src/pipeline/bounded_queue.h and src/pipeline/mailbox.h.
#include "pipeline/bounded_queue.h"

#include <atomic>
#include <memory>
#include <thread>

#include <gtest/gtest.h>

#include "pipeline/mailbox.h"

namespace aoscan {
namespace {

TEST(BoundedQueue, FifoOrder) {
  BoundedQueue<int> q(3, OverflowPolicy::kBlock);
  EXPECT_TRUE(q.push(1));
  EXPECT_TRUE(q.push(2));
  EXPECT_EQ(q.pop(), 1);
  EXPECT_EQ(q.pop(), 2);
}

TEST(BoundedQueue, BlockPolicyWaitsForRoom) {
  BoundedQueue<int> q(1, OverflowPolicy::kBlock);
  ASSERT_TRUE(q.push(1));
  std::atomic<bool> pushed{false};
  std::thread producer([&] {
    q.push(2);
    pushed = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(pushed.load()) << "push must wait while the queue is full";
  EXPECT_EQ(q.pop(), 1);
  producer.join();
  EXPECT_TRUE(pushed.load());
  EXPECT_EQ(q.pop(), 2);
  EXPECT_EQ(q.dropped(), 0u);
}

TEST(BoundedQueue, DropOldestNeverWaitsAndCounts) {
  BoundedQueue<int> q(2, OverflowPolicy::kDropOldest);
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(q.push(i));
  EXPECT_EQ(q.dropped(), 3u);
  EXPECT_EQ(q.pop(), 3);
  EXPECT_EQ(q.pop(), 4);
}

TEST(BoundedQueue, CloseWakesWaitersAndDrains) {
  BoundedQueue<int> q(1, OverflowPolicy::kBlock);
  std::thread consumer_waiting([&] { EXPECT_EQ(q.pop(), std::nullopt); });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  q.close();
  consumer_waiting.join();

  BoundedQueue<int> q2(1, OverflowPolicy::kBlock);
  q2.push(7);
  std::atomic<bool> refused{false};
  std::thread producer_waiting([&] { refused = !q2.push(8); });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  q2.close();
  producer_waiting.join();
  EXPECT_TRUE(refused.load());
  EXPECT_EQ(q2.pop(), 7);  // queued items survive close()
  EXPECT_EQ(q2.pop(), std::nullopt);
  EXPECT_FALSE(q2.push(9));
}

TEST(BoundedQueue, CloseAndClearDiscards) {
  BoundedQueue<std::shared_ptr<int>> q(4, OverflowPolicy::kBlock);
  auto item = std::make_shared<int>(5);
  q.push(item);
  EXPECT_EQ(item.use_count(), 2);
  q.close_and_clear();
  EXPECT_EQ(item.use_count(), 1);
  EXPECT_EQ(q.pop(), std::nullopt);
}

TEST(BoundedQueue, ManyProducersManyConsumersLoseNothing) {
  BoundedQueue<int> q(8, OverflowPolicy::kBlock);
  constexpr int kPerProducer = 5000;
  std::atomic<long> sum{0};
  std::atomic<int> count{0};
  std::vector<std::thread> threads;
  for (int p = 0; p < 3; ++p)
    threads.emplace_back([&, p] {
      for (int i = 0; i < kPerProducer; ++i) q.push(p * kPerProducer + i);
    });
  std::vector<std::thread> consumers;
  for (int c = 0; c < 2; ++c)
    consumers.emplace_back([&] {
      while (auto v = q.pop()) {
        sum += *v;
        ++count;
      }
    });
  for (auto& t : threads) t.join();
  q.close();
  for (auto& t : consumers) t.join();
  const long n = 3L * kPerProducer;
  EXPECT_EQ(count.load(), n);
  EXPECT_EQ(sum.load(), n * (n - 1) / 2);
}

TEST(Mailbox, LatestValueWins) {
  Mailbox<std::shared_ptr<const int>> box;
  EXPECT_FALSE(box.latest().has_value());
  box.put(std::make_shared<const int>(1));
  box.put(std::make_shared<const int>(2));
  const auto latest = box.latest();
  ASSERT_TRUE(latest.has_value());
  EXPECT_EQ(*latest->first, 2);
  EXPECT_EQ(latest->second, 2u);
}

TEST(Mailbox, WaitNewerWakesOnPutAndTimesOut) {
  Mailbox<int> box;
  box.put(1);
  EXPECT_FALSE(box.wait_newer(1, std::chrono::milliseconds(10)).has_value());
  std::thread producer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    box.put(5);
  });
  const auto got = box.wait_newer(1, std::chrono::seconds(10));
  producer.join();
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->first, 5);
}

}  // namespace
}  // namespace aoscan
