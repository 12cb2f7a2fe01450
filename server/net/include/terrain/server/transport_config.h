#pragma once

// Where and how a Server listens: the sockets' side of its settings. The protocol's settings
// (limits, rates, budgets, the journal's rules) are ServerConfig's (server_hub.h), which knows no
// addresses, ports or sockets.

#include <cstdint>
#include <string>

namespace terrain::server {

struct TransportConfig {
    std::string bind_address = "127.0.0.1";
    std::uint16_t port = 0; ///< 0: an ephemeral port (tests); see Server::port()
    /// HTTP for probes and scrapes on bind_address (GET /metrics, /livez, /readyz): -1 off, 0 an
    /// ephemeral port (Server::metricsPort()).
    int metrics_port = -1;
    /// SO_SNDBUF per session (0: the OS default). Small values bound kernel memory per client.
    int socket_send_buffer_bytes = 0;
};

} // namespace terrain::server
