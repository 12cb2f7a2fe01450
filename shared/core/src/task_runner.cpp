#include <terrain/task_runner.h>

#include <atomic>
#include <exception>

namespace terrain {

void forEachTask(
    TaskRunner* runner,
    std::size_t count,
    std::size_t min_count,
    const std::function<void(std::size_t)>& task) {
    if (runner != nullptr && runner->threads() > 1 && count >= min_count && count > 1) {
        runner->run(count, task);
        return;
    }
    for (std::size_t i = 0; i < count; ++i)
        task(i);
}

namespace {

constexpr int kSpins = 2000;

} // namespace

struct ThreadPool::Job {
    const std::function<void(std::size_t)>* task = nullptr;
    std::size_t count = 0;
    std::atomic<std::size_t> next{0};
    /// workers that took the job and have not left it: run() returns only once none has
    std::atomic<unsigned> users{0};
    std::mutex failure_mutex;
    std::exception_ptr failure; ///< the first task that threw (run() rethrows it)

    void drain() {
        try {
            for (std::size_t i = next.fetch_add(1); i < count; i = next.fetch_add(1))
                (*task)(i);
        } catch (...) {
            next.store(count); // the rest are not started
            std::lock_guard<std::mutex> lock(failure_mutex);
            if (!failure)
                failure = std::current_exception();
        }
    }
};

ThreadPool::ThreadPool(unsigned threads) {
    for (unsigned i = 1; i < threads; ++i)
        workers_.emplace_back([this] { work(); });
}

ThreadPool::~ThreadPool() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : workers_)
        t.join();
}

unsigned ThreadPool::hardwareThreads() {
    const unsigned n = std::thread::hardware_concurrency();
    return n == 0 ? 1 : n;
}

void ThreadPool::run(std::size_t count, const std::function<void(std::size_t)>& task) {
    if (workers_.empty() || count <= 1) {
        for (std::size_t i = 0; i < count; ++i)
            task(i);
        return;
    }
    Job job;
    job.task = &task;
    job.count = count;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        job_ = &job;
        ++generation_;
    }
    wake_.notify_all();
    job.drain();
    {
        // no worker can take the job after this; those that did finish their tasks
        std::lock_guard<std::mutex> lock(mutex_);
        job_ = nullptr;
    }
    while (job.users.load(std::memory_order_acquire) != 0)
        std::this_thread::yield();
    if (job.failure) // a task threw (allocation failure): no worker holds the job any more
        std::rethrow_exception(job.failure);
}

void ThreadPool::work() {
    std::size_t seen = 0;
    for (;;) {
        // a few tens of microseconds of watching before the condition variable
        for (int spin = 0; spin < kSpins && generation_.load(std::memory_order_acquire) == seen;
             ++spin)
            std::this_thread::yield();
        Job* job = nullptr;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            wake_.wait(lock, [&] { return stop_ || (job_ != nullptr && generation_ != seen); });
            if (stop_)
                return;
            seen = generation_;
            job = job_;
            job->users.fetch_add(1, std::memory_order_relaxed);
        }
        job->drain();
        job->users.fetch_sub(1, std::memory_order_release);
    }
}

} // namespace terrain
