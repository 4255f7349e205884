/// @file view_commands_test.cpp
/// @brief The command queue (order, bound, sticky flags, many producers) and the key mapping.
#include "render/view_commands.h"

#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "render/live_view.h"

namespace aoscan {
namespace {

TEST(ViewCommandQueue, FifoAndStickyFlags) {
  ViewCommandQueue q;
  EXPECT_FALSE(q.poll());
  EXPECT_TRUE(q.push(ViewCommand::kResetModel));
  EXPECT_TRUE(q.push(ViewCommand::kPauseIntegration));
  EXPECT_TRUE(q.integration_paused());
  EXPECT_TRUE(q.push(ViewCommand::kWriteOutputs));
  EXPECT_EQ(q.poll(), ViewCommand::kResetModel);
  EXPECT_EQ(q.drain(),
            (std::vector<ViewCommand>{ViewCommand::kPauseIntegration, ViewCommand::kWriteOutputs}));
  EXPECT_FALSE(q.quit_requested());
  q.push(ViewCommand::kResumeIntegration);
  EXPECT_FALSE(q.integration_paused());
  q.push(ViewCommand::kQuit);
  q.drain();
  EXPECT_TRUE(q.quit_requested());  // stays set after the command was taken
}

TEST(ViewCommandQueue, FullQueueDropsButQuitStillCounts) {
  ViewCommandQueue q;
  for (std::size_t i = 0; i < ViewCommandQueue::kCapacity; ++i)
    EXPECT_TRUE(q.push(ViewCommand::kWriteOutputs));
  EXPECT_FALSE(q.push(ViewCommand::kResetModel));
  EXPECT_FALSE(q.push(ViewCommand::kQuit));
  EXPECT_EQ(q.dropped(), 2u);
  EXPECT_TRUE(q.quit_requested());
  EXPECT_EQ(q.drain().size(), ViewCommandQueue::kCapacity);
}

TEST(ViewCommandQueue, ConcurrentProducersLoseNothingWithinCapacity) {
  ViewCommandQueue q;
  constexpr int kThreads = 4;
  constexpr int kEach = 200;
  std::size_t taken = 0;
  std::atomic<int> done{0};
  std::vector<std::thread> producers;
  for (int t = 0; t < kThreads; ++t)
    producers.emplace_back([&] {
      for (int i = 0; i < kEach; ++i)
        while (!q.push(ViewCommand::kWriteOutputs)) std::this_thread::yield();
      ++done;
    });
  while (done.load() < kThreads || taken < static_cast<std::size_t>(kThreads * kEach)) {
    if (q.poll()) ++taken;
  }
  for (auto& p : producers) p.join();
  EXPECT_EQ(taken, static_cast<std::size_t>(kThreads * kEach));
  EXPECT_FALSE(q.poll());
}

TEST(LiveViewKeys, EachKeyDoesItsJob) {
  ViewCommandQueue q;
  LiveViewState state;
  handle_key(Key::kV, state, q);
  EXPECT_EQ(state.view, View::kSsao);
  EXPECT_FALSE(q.poll());  // cycling views is local
  handle_key(Key::kR, state, q);
  EXPECT_EQ(q.poll(), ViewCommand::kResetModel);
  handle_key(Key::kSpace, state, q);
  EXPECT_TRUE(state.paused);
  EXPECT_EQ(q.poll(), ViewCommand::kPauseIntegration);
  handle_key(Key::kSpace, state, q);
  EXPECT_FALSE(state.paused);
  EXPECT_EQ(q.poll(), ViewCommand::kResumeIntegration);
  handle_key(Key::kS, state, q);
  EXPECT_EQ(q.poll(), ViewCommand::kWriteOutputs);
  EXPECT_FALSE(state.quit);
  handle_key(Key::kEscape, state, q);
  EXPECT_TRUE(state.quit);
  EXPECT_EQ(q.poll(), ViewCommand::kQuit);
  LiveViewState other;
  handle_key(Key::kQ, other, q);
  EXPECT_TRUE(other.quit);
  EXPECT_TRUE(q.quit_requested());
  for (int i = 0; i < kViewCount; ++i) handle_key(Key::kV, other, q);
  EXPECT_EQ(other.view, View::kShaded);  // full cycle
}

}  // namespace
}  // namespace aoscan
