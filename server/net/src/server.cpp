#include "server_metrics.h"
#include "session.h"
#include "status_http.h"
#include "tcp_listen.h"
#include "worker_thread.h"

#include <terrain/server/server.h>

#include <chrono>
#include <cstdio>

namespace terrain::server {

Server::Server(
    asio::io_context& io,
    TransportConfig transport,
    ServerConfig config,
    Authority& authority,
    journal::Journal* journal)
    : io_(io), acceptor_(io), log_(std::make_shared<LogWriter>()),
      metrics_(std::make_unique<ServerMetrics>()),
      status_http_(std::make_unique<StatusHttp>(
          io, [this](std::string_view path) { return statusPage(path); })),
      // snapshots are background work (the join cache is refreshed before anyone waits on it);
      // commits are on every deformer's path
      snapshot_worker_(std::make_unique<WorkerThread>(
          io,
          config.before_snapshot_build,
          WorkerThread::Options{.trim_after_each = true, .nice = 10})),
      commit_worker_(std::make_unique<WorkerThread>(io, nullptr, WorkerThread::Options{})),
      transport_(std::move(transport)), hub_(*this, std::move(config), authority, journal),
      shutdown_timer_(io), accept_retry_timer_(io) {
    hub_.on_broadcast = [this](std::uint64_t seq) {
        if (on_broadcast)
            on_broadcast(seq);
    };
}

Server::~Server() = default;

Status Server::start() {
    if (Status s = listenOn(acceptor_, transport_.bind_address, transport_.port, "listen"); !s)
        return s;
    port_ = acceptor_.local_endpoint().port();
    if (transport_.metrics_port >= 0)
        if (Status s = status_http_->listen(
                transport_.bind_address, static_cast<std::uint16_t>(transport_.metrics_port));
            !s)
            return s;
    accept();
    hub_.start();
    return Ok{};
}

void Server::setRecoveryReport(const RecoveryReport& report) {
    metrics_->setRecovery(report);
}

std::uint16_t Server::metricsPort() const {
    return status_http_->port();
}

HttpResponse Server::statusPage(std::string_view path) {
    if (path == "/metrics")
        return {200, "text/plain; version=0.0.4; charset=utf-8", metrics_->scrape(hub_)};
    if (path == "/livez") // the loop answered: it is not stuck
        return {200, "text/plain; charset=utf-8", "alive\n"};
    if (path == "/readyz") {
        if (hub_.failed())
            return {503, "text/plain; charset=utf-8", "failed: " + hub_.failure() + "\n"};
        if (hub_.shuttingDown())
            return {503, "text/plain; charset=utf-8", "draining\n"};
        return {200, "text/plain; charset=utf-8", "ready\n"};
    }
    return {404, "text/plain; charset=utf-8", "no such page: /metrics, /livez and /readyz\n"};
}

void Server::accept() {
    acceptor_.async_accept([this](const asio::error_code& ec, asio::ip::tcp::socket socket) {
        if (ec == asio::error::operation_aborted || !acceptor_.is_open())
            return;
        if (ec) {
            // e.g. out of file descriptors: back off instead of spinning on the error
            LogEvent e;
            e.level = LogLevel::kWarning;
            e.event = "server.accept_failed";
            e.message = "accept failed: " + ec.message() + "; retrying in 100 ms";
            log(e);
            scheduleAccept();
            return;
        }
        std::make_shared<Session>(hub_, std::move(socket), transport_.socket_send_buffer_bytes)
            ->start();
        accept();
    });
}

void Server::scheduleAccept() {
    accept_retry_timer_.expires_after(std::chrono::milliseconds(100));
    accept_retry_timer_.async_wait([this](const asio::error_code& ec) {
        if (!ec && acceptor_.is_open())
            accept();
    });
}

void Server::post(std::function<void()> fn) {
    asio::post(io_, std::move(fn));
}

namespace {

// the job, timed where it runs
HubHost::Job timed(HubHost::Job job, std::function<void(double)> observe) {
    return [job = std::move(job), observe = std::move(observe)] {
        const auto start = std::chrono::steady_clock::now();
        std::function<void()> then = job();
        observe(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        return then;
    };
}

} // namespace

void Server::runCommit(Job job) {
    commit_worker_->submit(
        timed(std::move(job), [m = metrics_.get()](double seconds) { m->observeCommit(seconds); }));
}

void Server::runSnapshot(Job job) {
    snapshot_worker_->submit(timed(std::move(job), [m = metrics_.get()](double seconds) {
        m->observeSnapshotBuild(seconds);
    }));
}

void Server::stopAccepting() {
    asio::error_code ignored;
    acceptor_.close(ignored);
}

std::int64_t Server::unixSeconds() const {
    return std::chrono::duration_cast<std::chrono::seconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
}

void Server::log(const LogEvent& event) {
    log_->write(event);
}

double Server::monotonicSeconds() const {
    return Session::now(); // the clock the sessions' `now` comes from
}

void Server::observe(HubTiming timing, double seconds) {
    metrics_->observe(timing, seconds);
}

void Server::shutdown(std::function<void()> done) {
    if (hub_.shuttingDown())
        return;
    hub_.shutdown([this, done = std::move(done)] {
        shutdown_timer_.cancel();
        done();
    });
    shutdown_timer_.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(hub_.config().close_linger_seconds + 0.5)));
    shutdown_timer_.async_wait([this](const asio::error_code& ec) {
        if (!ec)
            hub_.drainTimedOut();
    });
}

} // namespace terrain::server
