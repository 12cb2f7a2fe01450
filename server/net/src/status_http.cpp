#include "status_http.h"

#include "tcp_listen.h"

#include <chrono>
#include <memory>

namespace terrain::server {
namespace {

constexpr std::size_t kMaxHeadBytes = 8 << 10;
constexpr auto kHeadTimeout = std::chrono::seconds(5);

const char* reasonPhrase(int status) {
    switch (status) {
    case 200:
        return "OK";
    case 400:
        return "Bad Request";
    case 404:
        return "Not Found";
    case 405:
        return "Method Not Allowed";
    case 503:
        return "Service Unavailable";
    default:
        return "Status";
    }
}

HttpResponse plain(int status, std::string body) {
    return {status, "text/plain; charset=utf-8", std::move(body)};
}

/// One connection: read the head, answer, half-close, close once the peer has.
class Exchange : public std::enable_shared_from_this<Exchange> {
  public:
    Exchange(asio::ip::tcp::socket socket, const StatusHttp::Handler& handler)
        : socket_(std::move(socket)), handler_(handler), head_(kMaxHeadBytes),
          timer_(socket_.get_executor()) {}

    void start() {
        timer_.expires_after(kHeadTimeout);
        timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
            if (!ec) {
                asio::error_code ignored;
                self->socket_.close(ignored);
            }
        });
        asio::async_read_until(
            socket_, head_, "\r\n\r\n",
            [self = shared_from_this()](const asio::error_code& ec, std::size_t) {
                if (ec == asio::error::operation_aborted)
                    return;
                if (ec) {
                    // over 8 KiB (not_found) answers 400; a vanished peer gets nothing
                    if (ec == asio::error::not_found)
                        self->respond(plain(400, "request head over 8 KiB\n"));
                    return;
                }
                self->respond(self->route());
            });
    }

  private:
    HttpResponse route() {
        std::istream in(&head_);
        std::string method;
        std::string target;
        std::string version;
        in >> method >> target >> version;
        if (version.rfind("HTTP/1.", 0) != 0 || target.empty() || target[0] != '/')
            return plain(400, "expected 'GET /path HTTP/1.1'\n");
        if (method != "GET")
            return plain(405, "only GET is served\n");
        return handler_(std::string_view(target).substr(0, target.find('?')));
    }

    void respond(HttpResponse r) {
        reply_ = "HTTP/1.1 " + std::to_string(r.status) + " " + reasonPhrase(r.status) +
                 "\r\nContent-Type: " + r.content_type +
                 "\r\nContent-Length: " + std::to_string(r.body.size()) +
                 "\r\nConnection: close\r\n\r\n" + r.body;
        asio::async_write(
            socket_, asio::buffer(reply_),
            [self = shared_from_this()](const asio::error_code& ec, std::size_t) {
                if (ec)
                    return;
                // FIN after the reply; closed when the peer closes, or by the timer
                asio::error_code ignored;
                self->socket_.shutdown(asio::ip::tcp::socket::shutdown_send, ignored);
                self->drain();
            });
    }

    void drain() {
        socket_.async_read_some(
            asio::buffer(discard_),
            [self = shared_from_this()](const asio::error_code& ec, std::size_t) {
                if (ec) {
                    asio::error_code ignored;
                    self->timer_.cancel();
                    self->socket_.close(ignored);
                    return;
                }
                self->drain();
            });
    }

    asio::ip::tcp::socket socket_;
    const StatusHttp::Handler& handler_;
    asio::streambuf head_;
    asio::steady_timer timer_;
    std::string reply_;
    std::array<char, 512> discard_{};
};

} // namespace

StatusHttp::StatusHttp(asio::io_context& io, Handler handler)
    : io_(io), handler_(std::move(handler)), acceptor_(io) {}

Status StatusHttp::listen(const std::string& address, std::uint16_t port) {
    if (Status s = listenOn(acceptor_, address, port, "serve metrics"); !s)
        return s;
    port_ = acceptor_.local_endpoint().port();
    accept();
    return Ok{};
}

void StatusHttp::close() {
    asio::error_code ignored;
    acceptor_.close(ignored);
}

void StatusHttp::accept() {
    acceptor_.async_accept([this](const asio::error_code& ec, asio::ip::tcp::socket socket) {
        if (ec == asio::error::operation_aborted || !acceptor_.is_open())
            return;
        if (!ec)
            std::make_shared<Exchange>(std::move(socket), handler_)->start();
        accept();
    });
}

} // namespace terrain::server
