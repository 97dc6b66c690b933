#include <gtest/gtest.h>

#include <atomic>
#include <optional>
#include <thread>
#include <vector>

#include "slam/core/bounded_queue.hpp"
#include "slam/core/error.hpp"
#include "slam/core/prefetch.hpp"
#include "slam/core/stage_queue.hpp"

namespace coloc {
namespace {

TEST(BoundedQueue, KeepsOrderAndBlocksProducerWhenFull) {
  BoundedQueue<int> queue(2);
  std::vector<int> received;
  std::thread consumer([&] {
    while (auto v = queue.pop())
      received.push_back(*v);
  });
  for (int i = 0; i < 100; ++i) {
    ASSERT_TRUE(queue.push(i));
    EXPECT_LE(queue.size(), 2u);  // never grows past its capacity
  }
  queue.close();
  consumer.join();
  ASSERT_EQ(received.size(), 100u);
  for (int i = 0; i < 100; ++i)
    EXPECT_EQ(received[static_cast<std::size_t>(i)], i);
}

TEST(BoundedQueue, CloseDrainsThenEndsAndRefusesPush) {
  BoundedQueue<int> queue(4);
  EXPECT_TRUE(queue.push(1));
  EXPECT_TRUE(queue.push(2));
  queue.close();
  EXPECT_FALSE(queue.push(3));
  EXPECT_EQ(queue.pop().value(), 1);
  EXPECT_EQ(queue.pop().value(), 2);
  EXPECT_FALSE(queue.pop().has_value());
}

TEST(BoundedQueue, CloseWakesABlockedConsumerAndProducer) {
  BoundedQueue<int> empty(1);
  std::thread consumer([&] { EXPECT_FALSE(empty.pop().has_value()); });
  BoundedQueue<int> full(1);
  ASSERT_TRUE(full.push(0));
  std::thread producer([&] { EXPECT_FALSE(full.push(1)); });
  empty.close();
  full.close();
  consumer.join();
  producer.join();
}

TEST(StageQueue, IdleOnlyWhenEveryItemIsFinished) {
  StageQueue<int> stage(2);
  EXPECT_TRUE(stage.idle());
  ASSERT_TRUE(stage.push(1));
  EXPECT_FALSE(stage.idle());
  ASSERT_EQ(stage.pop(), 1);
  EXPECT_FALSE(stage.idle());  // popped but still in the consumer's hands
  std::thread consumer([&] { stage.finished(); });
  stage.wait_idle();
  consumer.join();
  EXPECT_TRUE(stage.idle());
}

TEST(StageQueue, CloseRefusesPushesAndWakesAnIdleWaiter) {
  StageQueue<int> stage(2);
  ASSERT_TRUE(stage.push(1));
  std::thread closer([&] { stage.close(); });
  stage.wait_idle();  // returns: closed, although the item was never finished
  closer.join();
  EXPECT_FALSE(stage.push(2));
  EXPECT_EQ(stage.size(), 1u);  // the refused item was not counted or queued
}

// Items in order, the producer's error where its item would have been, then the end.
TEST(Prefetch, HandsOutInOrderThenTheProducersErrorThenTheEnd) {
  int n = 0;
  Prefetch<int> ahead(
      [&n]() -> std::optional<int> {
        if (n == 5) throw Error("item 5 is broken");
        return n++;
      },
      2);
  for (int i = 0; i < 5; ++i)
    EXPECT_EQ(ahead.next(), i);
  EXPECT_THROW(ahead.next(), Error);
  EXPECT_FALSE(ahead.next());
}

// A consumer that leaves early stops the producer: no more than the queue and the item in hand.
TEST(Prefetch, LeavingEarlyStopsTheProducer) {
  std::atomic<int> produced{0};
  {
    Prefetch<int> ahead([&produced]() -> std::optional<int> { return produced++; }, 3);
    EXPECT_EQ(ahead.next(), 0);
  }
  EXPECT_LE(produced.load(), 5);  // 1 taken + 3 queued + 1 refused at the close
}

}  // namespace
}  // namespace coloc
