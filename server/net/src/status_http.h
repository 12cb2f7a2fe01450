#pragma once

// A minimal HTTP/1.1 responder for orchestrator probes and Prometheus scrapes, on the server's
// io thread: GET only, one request per connection (Connection: close), the request head at
// most 8 KiB and read within 5 s, anything else answered 400, 405 or 404 and closed. The routes
// are the caller's: a path in, a response out. Private to terrain_server_net.

#include <terrain/result.h>

#include <asio.hpp>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace terrain::server {

struct HttpResponse {
    int status = 200;
    std::string content_type = "text/plain; charset=utf-8";
    std::string body;
};

class StatusHttp {
  public:
    /// Io thread: the response to GET `path` (query string stripped).
    using Handler = std::function<HttpResponse(std::string_view path)>;

    StatusHttp(asio::io_context& io, Handler handler);

    /// Binds `address`:`port` (0: an ephemeral port) and starts accepting. Errors: kIo naming
    /// the address and the OS error.
    Status listen(const std::string& address, std::uint16_t port);
    std::uint16_t port() const { return port_; }
    /// Stops accepting and frees the port; exchanges in progress finish on their own.
    void close();

  private:
    void accept();

    asio::io_context& io_;
    Handler handler_;
    asio::ip::tcp::acceptor acceptor_;
    std::uint16_t port_ = 0;
};

} // namespace terrain::server
