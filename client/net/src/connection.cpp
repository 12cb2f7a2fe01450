#include <terrain/client/connection.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace terrain::client {

namespace {

std::chrono::steady_clock::duration seconds(double s) {
    return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(s));
}

std::string secondsText(double s) {
    char text[32];
    std::snprintf(text, sizeof text, "%g s", s);
    return text;
}

std::uint64_t nowNs() {
    return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                          std::chrono::steady_clock::now().time_since_epoch())
                                          .count());
}

} // namespace

Connection::Connection(asio::io_context& io, ConnectionConfig config, Replica& replica)
    : io_(io), config_(config), machine_(std::move(config), replica), socket_(io), resolver_(io),
      timer_(io), attempt_timer_(io) {
    machine_.on_deform_reply = [this](const DeformAnswer& a) {
        if (on_deform_reply)
            on_deform_reply(a);
    };
    machine_.on_height_reply = [this](const HeightAnswer& a) {
        if (on_height_reply)
            on_height_reply(a);
    };
    machine_.on_ray_reply = [this](const RayAnswer& a) {
        if (on_ray_reply)
            on_ray_reply(a);
    };
    machine_.on_applied = [this](std::uint64_t seq) {
        if (on_applied)
            on_applied(seq);
    };
}

Connection::~Connection() = default;

Connection::State Connection::state() const {
    switch (state_) {
    case Link::kIdle:
        return State::kIdle;
    case Link::kConnecting:
        return State::kConnecting;
    case Link::kLinked:
        return machine_.phase() == ClientMachine::Phase::kLive ? State::kLive : State::kJoining;
    case Link::kWaiting:
        return State::kWaiting;
    case Link::kClosed:
        break;
    }
    return State::kClosed;
}

void Connection::start() {
    down_since_ = std::chrono::steady_clock::now();
    connect();
}

void Connection::stop() {
    state_ = Link::kClosed;
    ++generation_;
    machine_.linkDown();
    asio::error_code ignored;
    timer_.cancel();
    attempt_timer_.cancel();
    resolver_.cancel(); // a lookup in flight must not hold up the io_context's end
    socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    socket_.close(ignored);
}

void Connection::dropForTesting() {
    lost("dropped by the test", false);
}

void Connection::connect() {
    if (state_ == Link::kClosed)
        return;
    state_ = Link::kConnecting;
    const std::uint64_t gen = ++generation_;
    writing_.clear();
    write_busy_ = false;
    socket_ = asio::ip::tcp::socket(io_);
    if (config_.connect_timeout_seconds > 0.0) {
        attempt_timer_.expires_after(seconds(config_.connect_timeout_seconds));
        attempt_timer_.async_wait([self = shared_from_this(), gen](const asio::error_code& ec) {
            if (ec || gen != self->generation_ || self->state_ != Link::kConnecting)
                return;
            self->lost(
                "connect: no answer from " + self->config_.host + ":" +
                    std::to_string(self->config_.port) + " within " +
                    secondsText(self->config_.connect_timeout_seconds),
                false);
        });
    }
    resolver_.async_resolve(
        config_.host, std::to_string(config_.port),
        [self = shared_from_this(), gen](const asio::error_code& ec, auto results) {
            if (gen != self->generation_)
                return;
            if (ec) {
                self->lost("resolve " + self->config_.host + ": " + ec.message(), false);
                return;
            }
            asio::async_connect(
                self->socket_, results,
                [self, gen](const asio::error_code& cec, const asio::ip::tcp::endpoint&) {
                    if (gen != self->generation_)
                        return;
                    if (cec) {
                        self->lost("connect: " + cec.message(), false);
                        return;
                    }
                    self->onConnected();
                });
        });
}

void Connection::onConnected() {
    attempt_timer_.cancel();
    ++machine_.counters().connects;
    asio::error_code ignored;
    socket_.set_option(asio::ip::tcp::no_delay(true), ignored);
    state_ = Link::kLinked;
    machine_.linkUp();
    afterMachine();
    readMore();
}

void Connection::readMore() {
    const std::uint64_t gen = generation_;
    std::span<std::uint8_t> space = machine_.readBuffer(64 << 10);
    socket_.async_read_some(
        asio::buffer(space.data(), space.size()),
        [self = shared_from_this(), gen](const asio::error_code& ec, std::size_t n) {
            if (gen != self->generation_)
                return;
            if (ec) {
                self->lost(
                    self->machine_.lastDisconnect().empty() ? "read: " + ec.message()
                                                            : self->machine_.lastDisconnect(),
                    false);
                return;
            }
            self->machine_.received(n, nowNs());
            self->afterMachine();
            if (gen != self->generation_)
                return; // a frame closed this socket
            self->readMore();
        });
}

void Connection::afterMachine() {
    if (state_ != Link::kLinked)
        return;
    if (!was_live_ && machine_.phase() == ClientMachine::Phase::kLive) {
        was_live_ = true;
        last_disconnect_.clear(); // a live link again: the old loss is history
    }
    if (const auto& drop = machine_.drop()) {
        const ClientMachine::Drop d = *drop;
        lost(d.why, d.final);
        return;
    }
    writeMore();
}

void Connection::writeMore() {
    if (write_busy_ || machine_.output().empty())
        return;
    writing_.clear();
    writing_.swap(machine_.output());
    write_busy_ = true;
    const std::uint64_t gen = generation_;
    asio::async_write(
        socket_, asio::buffer(writing_),
        [self = shared_from_this(), gen](const asio::error_code& ec, std::size_t n) {
            if (gen != self->generation_)
                return;
            self->write_busy_ = false;
            self->machine_.counters().bytes_out += n;
            if (ec) {
                self->lost("write: " + ec.message(), false);
                return;
            }
            self->writeMore();
        });
}

std::size_t Connection::applyArrived() {
    // called from the frame loop, not a handler: an on_applied callback may drop the last
    // owner of this connection
    const std::shared_ptr<Connection> self = shared_from_this();
    const std::size_t n = machine_.applyArrived();
    afterMachine();
    return n;
}

std::size_t Connection::applyAllArrived() {
    const std::shared_ptr<Connection> self = shared_from_this();
    const std::size_t n = machine_.applyAllArrived();
    afterMachine();
    return n;
}

std::uint32_t Connection::requestDeform(const OpRequest& request) {
    const std::uint32_t id = machine_.requestDeform(request);
    afterMachine();
    return id;
}

std::uint32_t Connection::requestDeform(const DeformOp& op) {
    const std::uint32_t id = machine_.requestDeform(op);
    afterMachine();
    return id;
}

std::uint32_t Connection::queryHeight(double x, double y) {
    const std::uint32_t id = machine_.queryHeight(x, y);
    afterMachine();
    return id;
}

std::uint32_t
Connection::castRay(const double origin[3], const double direction[3], double max_distance) {
    const std::uint32_t id = machine_.castRay(origin, direction, max_distance);
    afterMachine();
    return id;
}

void Connection::ping() {
    machine_.ping(nowNs());
    afterMachine();
}

void Connection::lost(const std::string& why, bool final_reason) {
    if (state_ == Link::kClosed)
        return;
    ++machine_.counters().disconnects;
    ++generation_;
    const bool was_live = machine_.phase() == ClientMachine::Phase::kLive;
    const auto now = std::chrono::steady_clock::now();
    if (was_live)
        down_since_ = now;
    was_live_ = false;
    machine_.linkDown();
    attempt_timer_.cancel();
    last_disconnect_ = why;
    asio::error_code ignored;
    socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    socket_.close(ignored);
    if (on_disconnect)
        on_disconnect(why);
    if (final_reason || !config_.reconnect) {
        state_ = Link::kClosed;
        return;
    }
    if (giveUpIfDue(now))
        return;
    state_ = Link::kWaiting;
    failed_attempts_ = was_live ? 0 : std::min(failed_attempts_ + 1, 30);
    const double delay = std::min(
        std::max(config_.reconnect_max_delay_seconds, config_.reconnect_delay_seconds),
        config_.reconnect_delay_seconds * std::ldexp(1.0, failed_attempts_));
    auto wait = seconds(delay);
    if (config_.give_up_seconds > 0.0) // wake to give up on time, not after a whole backoff
        wait = std::min(wait, down_since_ + seconds(config_.give_up_seconds) - now);
    timer_.expires_after(wait);
    timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
        if (ec || self->state_ != Link::kWaiting)
            return;
        if (!self->giveUpIfDue(std::chrono::steady_clock::now()))
            self->connect();
    });
}

bool Connection::giveUpIfDue(std::chrono::steady_clock::time_point now) {
    if (config_.give_up_seconds <= 0.0 || now - down_since_ < seconds(config_.give_up_seconds))
        return false;
    state_ = Link::kClosed;
    timer_.cancel();
    last_disconnect_ = "CONNECT_TIMEOUT: no live link to " + config_.host + ":" +
                       std::to_string(config_.port) + " for " +
                       secondsText(config_.give_up_seconds) +
                       "; gave up (last: " + last_disconnect_ + ")";
    if (on_disconnect)
        on_disconnect(last_disconnect_);
    return true;
}

} // namespace terrain::client
