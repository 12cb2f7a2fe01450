#include <terrain/server/agones_sdk.h>

#include <array>
#include <utility>

namespace terrain::server {

/// One POST: connect, write, read the status line, close. Ends once: on the answer, an error or
/// the timeout.
struct AgonesSdk::Call : std::enable_shared_from_this<AgonesSdk::Call> {
    Call(asio::io_context& io, std::string head_and_body, std::function<void(bool)> on_end)
        : socket(io), timer(io), request(std::move(head_and_body)), then(std::move(on_end)) {}

    void start(const asio::ip::tcp::endpoint& to, std::chrono::milliseconds timeout) {
        timer.expires_after(timeout);
        timer.async_wait([self = shared_from_this()](const asio::error_code& ec) {
            if (!ec)
                self->finish(false);
        });
        socket.async_connect(to, [self = shared_from_this()](const asio::error_code& ec) {
            if (ec)
                return self->finish(false);
            asio::async_write(
                self->socket, asio::buffer(self->request),
                [self](const asio::error_code& wec, std::size_t) {
                    if (wec)
                        return self->finish(false);
                    self->readStatus();
                });
        });
    }

    void readStatus() {
        asio::async_read_until(
            socket, answer, "\r\n",
            [self = shared_from_this()](const asio::error_code& ec, std::size_t) {
                if (ec)
                    return self->finish(false);
                std::istream in(&self->answer);
                std::string version;
                int status = 0;
                in >> version >> status;
                self->finish(version.rfind("HTTP/1.", 0) == 0 && status >= 200 && status < 300);
            });
    }

    void finish(bool ok) {
        if (done)
            return;
        done = true;
        timer.cancel();
        asio::error_code ignored;
        socket.close(ignored);
        then(ok);
    }

    asio::ip::tcp::socket socket;
    asio::steady_timer timer;
    std::string request;
    asio::streambuf answer{4096};
    std::function<void(bool)> then;
    bool done = false;
};

AgonesSdk::AgonesSdk(
    asio::io_context& io,
    Options options,
    std::function<bool()> healthy,
    std::shared_ptr<LogSink> log)
    : io_(io), options_(std::move(options)), healthy_(std::move(healthy)), log_(std::move(log)),
      timer_(io) {}

AgonesSdk::~AgonesSdk() {
    *alive_ = false;
}

void AgonesSdk::start() {
    log(LogLevel::kInfo, "agones.start",
        "Agones SDK over HTTP at " + options_.host + ":" + std::to_string(options_.port) +
            ": Ready, then Health every " + std::to_string(options_.health_every.count()) + " ms");
    sendReady();
}

void AgonesSdk::sendReady() {
    post("/ready", [this](bool ok) {
        if (stopping_)
            return;
        if (!ok) { // the sidecar may not be up yet
            timer_.expires_after(options_.ready_retry_every);
            timer_.async_wait([this, alive = alive_](const asio::error_code& ec) {
                if (!ec && *alive && !stopping_)
                    sendReady();
            });
            return;
        }
        ready_ = true;
        log(LogLevel::kInfo, "agones.ready", "Agones acknowledged Ready");
        schedulePing();
    });
}

void AgonesSdk::schedulePing() {
    timer_.expires_after(options_.health_every);
    timer_.async_wait([this, alive = alive_](const asio::error_code& ec) {
        if (ec || !*alive || stopping_)
            return;
        if (!healthy_()) // no ping: Agones counts the missed periods and marks it Unhealthy
            return schedulePing();
        post("/health", [this](bool ok) {
            if (stopping_)
                return;
            if (ok) {
                ++health_acks_;
                if (health_failing_)
                    log(LogLevel::kInfo, "agones.health_ok", "Agones answers health pings again");
                health_failing_ = false;
            } else if (!health_failing_) { // once per outage, not once per ping
                health_failing_ = true;
                log(LogLevel::kWarning, "agones.health_failed",
                    "Agones SDK did not acknowledge a health ping");
            }
            schedulePing();
        });
    });
}

void AgonesSdk::shutdown(std::function<void()> done) {
    stopping_ = true;
    timer_.cancel();
    post("/shutdown", [this, done = std::move(done)](bool ok) {
        log(ok ? LogLevel::kInfo : LogLevel::kWarning, "agones.shutdown",
            ok ? "Agones acknowledged Shutdown"
               : "Agones SDK did not acknowledge Shutdown (the pod ends with the process anyway)");
        done();
    });
}

void AgonesSdk::post(const std::string& path, std::function<void(bool ok)> then) {
    asio::error_code ec;
    const asio::ip::address address = asio::ip::make_address(options_.host, ec);
    if (ec) {
        asio::post(io_, [then = std::move(then)] { then(false); });
        return;
    }
    std::string request = "POST " + path + " HTTP/1.1\r\nHost: " + options_.host +
                          "\r\nContent-Type: application/json\r\nContent-Length: 2\r\n"
                          "Connection: close\r\n\r\n{}";
    auto call = std::make_shared<Call>(
        io_, std::move(request), [alive = alive_, then = std::move(then)](bool ok) {
            if (*alive)
                then(ok);
        });
    call->start({address, options_.port}, options_.call_timeout);
}

void AgonesSdk::log(LogLevel level, const std::string& event, const std::string& message) {
    if (!log_)
        return;
    LogEvent e;
    e.level = level;
    e.event = event;
    e.source = "agones";
    e.message = message;
    log_->write(e);
}

} // namespace terrain::server
