#pragma once

// Work the io thread hands off so that it never stalls the sessions it carries, on a thread of
// its own: the server has two, one for snapshots (join snapshots: encode, compress, chunk, tens
// to hundreds of milliseconds on a grown world; the journal's snapshot files: encode, write,
// fsync), one for the journal's group commits (write + fdatasync). A job returns what the io
// thread runs once it is done, posted to its io_context. Jobs run one at a time, in order.
// Private to terrain_server_net.

#include <asio.hpp>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>

namespace terrain::server {

class WorkerThread {
  public:
    /// Runs on the worker's thread; returns what the io thread runs afterwards.
    using Job = std::function<std::function<void()>()>;

    struct Options {
        /// Each job's freed memory goes back to the system (glibc's malloc_trim): for jobs of
        /// tens of MB, not for frequent small ones.
        bool trim_after_each = false;
        /// The thread's nice value (Linux; 0 elsewhere): background work that no one waits on
        /// yields the CPU to the io thread, whose tail latency it would otherwise take.
        int nice = 0;
    };

    /// `before_each` (may be empty) runs on the worker's thread before each job (tests).
    WorkerThread(asio::io_context& io, std::function<void()> before_each, Options options);
    /// Stops the thread after the job in progress; jobs not started, and completions not yet
    /// run, are dropped.
    ~WorkerThread();
    WorkerThread(const WorkerThread&) = delete;
    WorkerThread& operator=(const WorkerThread&) = delete;

    /// Io thread: queues `job`.
    void submit(Job job);

  private:
    void run();

    asio::io_context& io_;
    std::function<void()> before_each_;
    Options options_;
    /// Completions hold a weak reference and do nothing once it is gone (io thread only).
    std::shared_ptr<bool> alive_ = std::make_shared<bool>(true);
    const std::weak_ptr<bool> alive_weak_ = alive_; ///< what the worker copies (never written)
    std::mutex mutex_;
    std::condition_variable wake_;
    std::deque<Job> jobs_; ///< guarded by mutex_
    bool stop_ = false;    ///< guarded by mutex_
    std::thread thread_;
};

} // namespace terrain::server
