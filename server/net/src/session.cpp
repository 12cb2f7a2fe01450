#include "session.h"

#include <chrono>
#include <cmath>

namespace terrain::server {

namespace {

// frames are gathered into one write up to this many bytes
constexpr std::size_t kMaxGatherBytes = 256 << 10;
constexpr std::size_t kReadChunk = 16 << 10;

} // namespace

Session::Session(ServerHub& hub, asio::ip::tcp::socket socket, int send_buffer_bytes)
    : hub_(hub), socket_(std::move(socket)), send_buffer_bytes_(send_buffer_bytes),
      timer_(socket_.get_executor()) {}

Session::~Session() {
    if (machine_)
        machine_->attach(nullptr);
}

double Session::now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

void Session::start() {
    asio::error_code ec;
    socket_.set_option(asio::ip::tcp::no_delay(true), ec);
    if (send_buffer_bytes_ > 0)
        socket_.set_option(asio::socket_base::send_buffer_size(send_buffer_bytes_), ec);
    const auto endpoint = socket_.remote_endpoint(ec);
    std::string peer =
        ec ? "?" : endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
    // the machine may queue its refusal (a full server) before addSession returns: what it
    // queued is written once machine_ is set
    machine_ = hub_.addSession(std::move(peer), now(), this);
    writeMore();
    readMore();
}

void Session::readMore() {
    if (reading_ || closed_)
        return;
    if (reading_stopped_) {
        drain();
        return;
    }
    std::span<std::uint8_t> space = machine_->readBuffer(kReadChunk);
    reading_ = true;
    socket_.async_read_some(
        asio::buffer(space.data(), space.size()),
        [self = shared_from_this()](const asio::error_code& ec, std::size_t n) {
            self->reading_ = false;
            if (self->closed_ || self->reading_stopped_) {
                // closing: the Disconnect is being written; what the peer still sends is read
                // and dropped, so that the close sends no reset ahead of it
                if (!ec)
                    self->drain();
                return;
            }
            if (ec) {
                self->machine_->linkLost();
                return;
            }
            self->machine_->received(n, now());
            self->readMore();
        });
}

void Session::writeMore() {
    if (closed_)
        return;
    const std::size_t n = machine_->beginWrite(kMaxGatherBytes);
    if (n == 0)
        return;
    gather_.clear();
    for (std::size_t i = 0; i < n; ++i) {
        const wire::Frame& f = machine_->outbound().at(i).frame;
        gather_.emplace_back(f->data(), f->size());
    }
    asio::async_write(
        socket_, gather_, [self = shared_from_this()](const asio::error_code& ec, std::size_t) {
            if (self->closed_)
                return;
            self->machine_->endWrite(!ec);
        });
}

void Session::framesQueued() {
    if (machine_)
        writeMore();
}

void Session::setDeadline(double at) {
    if (closed_)
        return;
    if (std::isinf(at)) {
        timer_.cancel();
        return;
    }
    timer_.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(std::max(0.0, at - now()))));
    timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
        if (!ec && !self->closed_)
            self->machine_->tick(now());
    });
}

void Session::stopReading() {
    reading_stopped_ = true;
    if (!reading_)
        drain();
}

void Session::drain() {
    if (reading_ || !socket_.is_open())
        return;
    discard_.resize(kReadChunk);
    reading_ = true;
    socket_.async_read_some(
        asio::buffer(discard_),
        [self = shared_from_this()](const asio::error_code& ec, std::size_t) {
            self->reading_ = false;
            if (ec) {
                if (self->closed_)
                    self->closeSocket(); // the peer closed its side (or the link broke)
                return;
            }
            self->drain();
        });
}

void Session::closeLink() {
    closed_ = true;
    reading_stopped_ = true;
    asio::error_code ignored;
    // the FIN follows the last frame written; the peer reads it all, then closes its side, and
    // the drain closes ours. A peer that keeps sending is cut off after the linger
    socket_.shutdown(asio::ip::tcp::socket::shutdown_send, ignored);
    timer_.cancel();
    timer_.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(hub_.config().close_linger_seconds)));
    timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
        if (!ec)
            self->closeSocket();
    });
    drain();
}

void Session::closeSocket() {
    asio::error_code ignored;
    timer_.cancel();
    socket_.close(ignored);
}

} // namespace terrain::server
