#include "worker_thread.h"

#include <utility>

#ifdef __GLIBC__
#include <malloc.h>
#endif
#ifdef __linux__
#include <sys/resource.h>
#include <unistd.h>
#endif

namespace terrain::server {

WorkerThread::WorkerThread(asio::io_context& io, std::function<void()> before_each, Options options)
    : io_(io), before_each_(std::move(before_each)), options_(options), thread_([this] { run(); }) {
}

WorkerThread::~WorkerThread() {
    alive_.reset();
    {
        const std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
        jobs_.clear();
    }
    wake_.notify_one();
    thread_.join();
}

void WorkerThread::submit(Job job) {
    {
        const std::lock_guard<std::mutex> lock(mutex_);
        jobs_.push_back(std::move(job));
    }
    wake_.notify_one();
}

void WorkerThread::run() {
#ifdef __linux__
    // per thread on Linux (a thread id names one thread); best effort: a failure leaves it at 0
    if (options_.nice != 0)
        (void)setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), options_.nice);
#endif
    for (;;) {
        Job job;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            wake_.wait(lock, [this] { return stop_ || !jobs_.empty(); });
            if (stop_)
                return;
            job = std::move(jobs_.front());
            jobs_.pop_front();
        }
        if (before_each_)
            before_each_();
        std::function<void()> done = job();
        job = nullptr; // what it captured (a terrain copy) is freed here, off the io thread
        asio::post(io_, [alive = alive_weak_, done = std::move(done)] {
            if (!alive.expired())
                done();
        });
#ifdef __GLIBC__
        // a snapshot job's buffers (a terrain copy, the raw and compressed snapshot) are tens of
        // MB that glibc keeps in this thread's arena once freed; a server holds its resident set
        // to what it uses between builds only if they go back to the system
        if (options_.trim_after_each)
            malloc_trim(0);
#endif
    }
}

} // namespace terrain::server
