#pragma once

// Where Terrain::apply may spread work that cannot depend on its order (the cells of one op,
// the tiles it dirtied): each task writes only its own slots, so the bits are the same whatever
// runs them. The core owns no threads; callers pass a runner, or none for the serial path.

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace terrain {

class TaskRunner {
  public:
    virtual ~TaskRunner() = default;
    /// Runs task(i) for every i in [0, count), possibly on several threads, the caller's among
    /// them; returns once all have returned. A task that throws (an allocation failure) stops
    /// the tasks not yet started, and run() rethrows it once no thread holds the job.
    virtual void run(std::size_t count, const std::function<void(std::size_t)>& task) = 0;
    /// Threads that may run tasks at once, the caller's included.
    virtual unsigned threads() const = 0;
};

/// task(i) for i in [0, count): on `runner` when there is one with more than one thread and at
/// least `min_count` tasks, else on the caller, in order.
void forEachTask(
    TaskRunner* runner,
    std::size_t count,
    std::size_t min_count,
    const std::function<void(std::size_t)>& task);

/// `threads - 1` worker threads plus the caller. A job's tasks are handed out one index at a time
/// (an atomic counter), so uneven tasks balance themselves. After a job the workers watch for the
/// next one for a short while (the phases of one op follow each other within microseconds, and
/// a wake from a condition variable costs tens of them), then sleep on a condition variable.
/// @note run() is called by one thread at a time (the owner's).
class ThreadPool final : public TaskRunner {
  public:
    /// `threads` of 0 or 1: no workers, run() is a plain loop.
    explicit ThreadPool(unsigned threads);
    ~ThreadPool() override;
    ThreadPool(const ThreadPool&) = delete;
    ThreadPool& operator=(const ThreadPool&) = delete;

    void run(std::size_t count, const std::function<void(std::size_t)>& task) override;
    unsigned threads() const override { return static_cast<unsigned>(workers_.size()) + 1; }

    /// The default for a "threads" setting: the machine's hardware threads (at least 1).
    static unsigned hardwareThreads();

  private:
    struct Job;
    void work();

    std::vector<std::thread> workers_;
    std::mutex mutex_;
    std::condition_variable wake_;
    Job* job_ = nullptr; ///< guarded by mutex_: the job being handed out, if any
    std::atomic<std::size_t> generation_{0}; ///< bumped per job (under mutex_ too)
    bool stop_ = false;                      ///< guarded by mutex_
};

} // namespace terrain
