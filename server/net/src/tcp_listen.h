#pragma once

// Opens, binds and listens an acceptor on address:port, for the game port and the HTTP port
// alike. Private to terrain_server_net.

#include <terrain/result.h>

#include <asio.hpp>
#include <cstdint>
#include <string>

namespace terrain::server {

/// Errors: kOutOfRange for an address that does not parse, kIo naming `what`, the address and
/// the OS error.
inline Status listenOn(
    asio::ip::tcp::acceptor& acceptor,
    const std::string& address,
    std::uint16_t port,
    const std::string& what) {
    asio::error_code ec;
    const asio::ip::address ip = asio::ip::make_address(address, ec);
    if (ec)
        return makeError(
            ErrorCode::kOutOfRange, what + " address '" + address + "': " + ec.message());
    const asio::ip::tcp::endpoint endpoint(ip, port);
    acceptor.open(endpoint.protocol(), ec);
    if (!ec)
        acceptor.set_option(asio::ip::tcp::acceptor::reuse_address(true), ec);
    if (!ec)
        acceptor.bind(endpoint, ec);
    if (!ec)
        acceptor.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
        return makeError(
            ErrorCode::kIo,
            "cannot " + what + " on " + address + ":" + std::to_string(port) + ": " + ec.message());
    return Ok{};
}

} // namespace terrain::server
