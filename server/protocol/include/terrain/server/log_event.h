#pragma once

// One event for the server's log. The protocol code makes events; the edge chooses their form
// (LogWriter in terrain_server_net: today's text lines, or one JSON object per line).

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace terrain::server {

enum class LogLevel : std::uint8_t { kInfo, kWarning, kError };

struct LogEvent {
    LogLevel level = LogLevel::kInfo;
    /// Dotted name, stable for log queries: "session.join", "session.close", "server.fatal".
    std::string event;
    /// Where a text line says it came from ("server", "journal"); sessions use their id.
    std::string source = "server";
    std::string message;       ///< what a person reads
    std::uint64_t session = 0; ///< 0: not a session's event
    std::string peer;          ///< a session's address:port
    /// Further facts, each also a JSON member (values as strings; numbers where `numeric`).
    struct Field {
        std::string key;
        std::string value;
        bool numeric = false;
    };
    std::vector<Field> fields;
};

/// Where events go. Implementations decide the form and the stream.
class LogSink {
  public:
    virtual ~LogSink() = default;
    virtual void write(const LogEvent& event) = 0;
};

} // namespace terrain::server
