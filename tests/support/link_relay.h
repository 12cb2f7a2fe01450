#pragma once

// A simulated network link on loopback: a TCP relay that delivers each direction's bytes at a
// fixed rate after a fixed one-way delay, as a bottleneck link of that bandwidth and round trip
// would. Used where tc netem cannot be (this kernel has no sch_netem; CI runs unprivileged).
// Each chunk the relay reads leaves the bottleneck at max(now, when the link is free) + its
// serialisation time (bytes * 8 / rate) and arrives one delay later. The relay reads as fast as
// loopback gives (a deep router buffer), so what it does not model is TCP's own ramp-up: on a
// real path of this round trip, slow start adds a few round trips to a large transfer.

#include "support/loopback.h"

#include <asio.hpp>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <vector>

namespace terrain::testing {

struct LinkShape {
    double bits_per_second = 20e6;
    double round_trip_seconds = 0.040; ///< each direction gets half
};

class LinkRelay {
  public:
    /// Listens on 127.0.0.1 (an ephemeral port) and relays every connection to `upstream_port`.
    LinkRelay(std::uint16_t upstream_port, LinkShape shape)
        : upstream_port_(upstream_port), shape_(shape), acceptor_(thread_.io()) {
        thread_.call([this] {
            const asio::ip::tcp::endpoint any(asio::ip::make_address("127.0.0.1"), 0);
            acceptor_.open(any.protocol());
            acceptor_.bind(any);
            acceptor_.listen();
            port_ = acceptor_.local_endpoint().port();
            accept();
            return 0;
        });
    }
    ~LinkRelay() {
        thread_.call([this] {
            asio::error_code ignored;
            acceptor_.close(ignored);
            for (auto& p : pumps_)
                p->shut();
            return 0;
        });
        thread_.join();
    }
    LinkRelay(const LinkRelay&) = delete;
    LinkRelay& operator=(const LinkRelay&) = delete;

    std::uint16_t port() const { return port_; }

  private:
    using Clock = std::chrono::steady_clock;

    /// One direction of one connection.
    struct Pump : std::enable_shared_from_this<Pump> {
        Pump(
            std::shared_ptr<asio::ip::tcp::socket> from,
            std::shared_ptr<asio::ip::tcp::socket> to,
            LinkShape shape)
            : from_(std::move(from)), to_(std::move(to)), shape_(shape),
              timer_(from_->get_executor()) {}

        void start() { read(); }
        void shut() {
            asio::error_code ignored;
            from_->close(ignored);
            to_->close(ignored);
            timer_.cancel();
        }

      private:
        struct Chunk {
            Clock::time_point due;
            std::vector<std::uint8_t> bytes;
        };

        void read() {
            auto self = shared_from_this();
            from_->async_read_some(
                asio::buffer(buffer_), [self](const asio::error_code& ec, std::size_t n) {
                    if (ec) {
                        self->closing_ = true;
                        if (self->queue_.empty() && !self->writing_)
                            self->shut();
                        return;
                    }
                    const Clock::time_point now = Clock::now();
                    const auto serialise =
                        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                            static_cast<double>(n) * 8.0 / self->shape_.bits_per_second));
                    const auto delay = std::chrono::duration_cast<Clock::duration>(
                        std::chrono::duration<double>(self->shape_.round_trip_seconds / 2.0));
                    self->link_free_ = std::max(now, self->link_free_) + serialise;
                    self->queue_.push_back(
                        {self->link_free_ + delay,
                         std::vector<std::uint8_t>(
                             self->buffer_.begin(),
                             self->buffer_.begin() + static_cast<std::ptrdiff_t>(n))});
                    if (self->queue_.size() == 1 && !self->writing_)
                        self->deliver();
                    self->read();
                });
        }

        void deliver() {
            if (queue_.empty()) {
                if (closing_)
                    shut();
                return;
            }
            auto self = shared_from_this();
            timer_.expires_at(queue_.front().due);
            writing_ = true;
            timer_.async_wait([self](const asio::error_code& ec) {
                if (ec) {
                    self->writing_ = false;
                    return;
                }
                asio::async_write(
                    *self->to_, asio::buffer(self->queue_.front().bytes),
                    [self](const asio::error_code& wec, std::size_t) {
                        self->writing_ = false;
                        if (wec) {
                            self->shut();
                            return;
                        }
                        self->queue_.pop_front();
                        self->deliver();
                    });
            });
        }

        std::shared_ptr<asio::ip::tcp::socket> from_;
        std::shared_ptr<asio::ip::tcp::socket> to_;
        LinkShape shape_;
        asio::steady_timer timer_;
        std::array<std::uint8_t, 16 << 10> buffer_{};
        std::deque<Chunk> queue_;
        Clock::time_point link_free_{};
        bool writing_ = false;
        bool closing_ = false;
    };

    void accept() {
        acceptor_.async_accept([this](const asio::error_code& ec, asio::ip::tcp::socket socket) {
            if (ec)
                return;
            auto client = std::make_shared<asio::ip::tcp::socket>(std::move(socket));
            auto server = std::make_shared<asio::ip::tcp::socket>(thread_.io());
            asio::error_code cec;
            server->connect(
                {asio::ip::make_address("127.0.0.1"), upstream_port_}, cec); // loopback: at once
            if (!cec) {
                client->set_option(asio::ip::tcp::no_delay(true));
                server->set_option(asio::ip::tcp::no_delay(true));
                auto up = std::make_shared<Pump>(client, server, shape_);
                auto down = std::make_shared<Pump>(server, client, shape_);
                pumps_.push_back(up);
                pumps_.push_back(down);
                up->start();
                down->start();
            }
            accept();
        });
    }

    IoThread thread_; // first: outlives the sockets whose handlers it holds
    std::uint16_t upstream_port_;
    LinkShape shape_;
    asio::ip::tcp::acceptor acceptor_;
    std::uint16_t port_ = 0;
    std::vector<std::shared_ptr<Pump>> pumps_;
};

} // namespace terrain::testing
