// The thread pool behind Terrain::apply's runner: every task of every job runs exactly once, the
// job is over when run() returns, and jobs follow each other without a stale worker taking a
// task of the next one.

#include <terrain/task_runner.h>

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

namespace terrain {
namespace {

TEST(ThreadPool, EveryTaskOfEveryJobRunsOnceAndIsDoneWhenRunReturns) {
    for (unsigned threads : {0u, 1u, 2u, 4u, 8u}) {
        ThreadPool pool(threads);
        EXPECT_EQ(pool.threads(), threads == 0 ? 1u : threads);
        for (std::size_t count : {0u, 1u, 2u, 3u, 17u, 1000u}) {
            for (int job = 0; job < 50; ++job) {
                std::vector<std::atomic<int>> runs(count);
                pool.run(count, [&](std::size_t i) { runs[i].fetch_add(1); });
                for (std::size_t i = 0; i < count; ++i)
                    ASSERT_EQ(runs[i].load(), 1) << threads << " threads, " << count
                                                 << " tasks, job " << job << ", task " << i;
            }
        }
    }
}

TEST(ThreadPool, ATaskThatThrowsStopsTheJobAndRunRethrowsOnceNoThreadHoldsIt) {
    ThreadPool pool(4);
    for (int job = 0; job < 20; ++job) {
        std::atomic<int> ran{0};
        EXPECT_THROW(
            pool.run(
                200,
                [&](std::size_t i) {
                    ran.fetch_add(1);
                    if (i == 7)
                        throw std::runtime_error("task 7");
                }),
            std::runtime_error);
        EXPECT_GE(ran.load(), 8);
        // the pool goes on
        std::atomic<int> after{0};
        pool.run(50, [&](std::size_t) { after.fetch_add(1); });
        EXPECT_EQ(after.load(), 50);
    }
}

TEST(ThreadPool, ForEachTaskRunsSmallJobsOnTheCallerInOrder) {
    ThreadPool pool(4);
    std::vector<std::size_t> order;
    forEachTask(&pool, 3, 4, [&](std::size_t i) { order.push_back(i); }); // below min_count
    EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2}));
    order.clear();
    forEachTask(nullptr, 5, 1, [&](std::size_t i) { order.push_back(i); });
    EXPECT_EQ(order.size(), 5u);
    std::atomic<int> sum{0};
    forEachTask(&pool, 100, 4, [&](std::size_t i) { sum.fetch_add(static_cast<int>(i)); });
    EXPECT_EQ(sum.load(), 4950);
}

} // namespace
} // namespace terrain
