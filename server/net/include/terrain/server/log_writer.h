#pragma once

// The server's log on a stream, one event per line: today's text ("session 3 (1.2.3.4:5):
// closing: ...", "journal: ..."), or JSON Lines for log pipelines (`--log-format json`): an
// object per line with time (UTC, ms), level, event, message, and session, peer and the
// event's own fields where it has them. Lines are written whole and flushed, so a container's
// log driver never sees half an event.

#include <terrain/server/log_event.h>

#include <cstdio>
#include <mutex>
#include <string>

namespace terrain::server {

enum class LogFormat : std::uint8_t { kText, kJson };

class LogWriter : public LogSink {
  public:
    explicit LogWriter(LogFormat format = LogFormat::kText, std::FILE* out = stdout);

    void write(const LogEvent& event) override;
    /// A plain event from the edge (main, the acceptor): `source` says where it came from.
    void info(const std::string& event, const std::string& source, const std::string& message);
    void error(const std::string& event, const std::string& source, const std::string& message);

    /// The line `event` becomes (no newline).
    std::string format(const LogEvent& event) const;

  private:
    void writePlain(
        LogLevel level,
        const std::string& event,
        const std::string& source,
        const std::string& message);

    LogFormat format_;
    std::FILE* out_;
    std::mutex mutex_; ///< workers and the io thread may log at once
};

} // namespace terrain::server
