#pragma once

// What loopback tests and the network benchmark share, without GoogleTest: the token secret and
// minting, and an io_context on its own thread.

#include <terrain/server/auth_token.h>

#include <asio.hpp>
#include <chrono>
#include <cstdint>
#include <future>
#include <string>
#include <thread>
#include <vector>

namespace terrain::testing {

inline const std::vector<std::uint8_t>& testSecret() {
    static const std::vector<std::uint8_t> secret = [] {
        const std::string s = "loopback-test-secret-0123456789";
        return std::vector<std::uint8_t>(s.begin(), s.end());
    }();
    return secret;
}

inline std::int64_t unixNow() {
    return std::chrono::duration_cast<std::chrono::seconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
}

inline std::string token(std::uint64_t player, server::Role role, std::int64_t ttl = 3600) {
    return server::mintToken({player, role, unixNow() + ttl}, testSecret());
}

/// An io_context on its own thread; call() runs a function there and waits for its result.
class IoThread {
  public:
    IoThread() : work_(asio::make_work_guard(io_)), thread_([this] { io_.run(); }) {}
    ~IoThread() { join(); }
    IoThread(const IoThread&) = delete;
    IoThread& operator=(const IoThread&) = delete;

    /// Stops the loop (handlers not yet run are dropped) and joins the thread.
    void join() {
        if (!thread_.joinable())
            return;
        work_.reset();
        io_.stop();
        thread_.join();
    }
    bool running() const { return thread_.joinable(); }
    template <typename F> auto call(F f) -> decltype(f()) {
        std::packaged_task<decltype(f())()> task(std::move(f));
        auto result = task.get_future();
        asio::post(io_, [&task] { task(); });
        return result.get();
    }
    asio::io_context& io() { return io_; }

  private:
    asio::io_context io_{1};
    asio::executor_work_guard<asio::io_context::executor_type> work_;
    std::thread thread_;
};

} // namespace terrain::testing
