#pragma once

// Builds and writes snapshots on a thread of its own: join snapshots (encode, compress, chunk:
// tens to hundreds of milliseconds on a grown world) and the journal's snapshot files (encode,
// write, fsync), so that neither stalls the io thread that carries every session's ops. The io
// thread hands over a copy of the terrain (a memory copy, far cheaper than the encoding); a job
// returns what the io thread runs once it is done, posted to its io_context. Jobs run one at a
// time, in order. Private to terrain_server_net.

#include <asio.hpp>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>

namespace terrain::server {

class SnapshotWorker {
  public:
    /// Runs on the worker's thread; returns what the io thread runs afterwards.
    using Job = std::function<std::function<void()>()>;

    /// `before_each` (may be empty) runs on the worker's thread before each job (tests).
    SnapshotWorker(asio::io_context& io, std::function<void()> before_each);
    /// Stops the thread after the job in progress; jobs not started, and completions not yet
    /// run, are dropped.
    ~SnapshotWorker();
    SnapshotWorker(const SnapshotWorker&) = delete;
    SnapshotWorker& operator=(const SnapshotWorker&) = delete;

    /// Io thread: queues `job`.
    void submit(Job job);

  private:
    void run();

    asio::io_context& io_;
    std::function<void()> before_each_;
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
