// A stepping thread's count of its waits for a caller's lock (lamina/core/lock_waits.h): a lock
// nobody holds is no wait; a lock another thread holds is one wait, as long as it was held.
#include "lamina/core/lock_waits.h"

#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <thread>

namespace {

using namespace lamina;

TEST(LockWaits, AFreeLockIsNoWaitAndAHeldOneIsOneWaitAsLongAsItWasHeld) {
  std::mutex mutex;
  LockWaits waits;
  {
    std::unique_lock lock(mutex, std::defer_lock);
    waits.acquire(lock);
    EXPECT_TRUE(lock.owns_lock());
  }
  EXPECT_EQ(waits.count, 0);
  EXPECT_EQ(waits.longest_us, 0.0);

  std::promise<void> held;
  std::thread holder([&] {
    std::lock_guard guard(mutex);
    held.set_value();
    std::this_thread::sleep_for(std::chrono::milliseconds(40));
  });
  held.get_future().wait();  // the holder has the lock before we ask for it
  {
    std::unique_lock lock(mutex, std::defer_lock);
    waits.acquire(lock);
    EXPECT_TRUE(lock.owns_lock());
  }
  holder.join();
  EXPECT_EQ(waits.count, 1);
  // The holder slept 40 ms after telling us; we asked at most a few ms after that.
  EXPECT_GT(waits.longest_us, 20e3);
  EXPECT_LT(waits.longest_us, 10e6);
}

}  // namespace
