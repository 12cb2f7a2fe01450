#include <terrain/server/log_writer.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <ctime>

namespace terrain::server {
namespace {

const char* levelName(LogLevel level) {
    switch (level) {
    case LogLevel::kInfo:
        return "info";
    case LogLevel::kWarning:
        return "warning";
    case LogLevel::kError:
        return "error";
    }
    return "info";
}

// 2026-12-03T15:06:16.123Z
std::string utcNow() {
    const auto now = std::chrono::system_clock::now();
    const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
    const auto ms =
        std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() %
        1000;
    std::tm utc{};
    gmtime_r(&seconds, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S", &utc);
    char out[40];
    std::snprintf(out, sizeof out, "%s.%03dZ", text, static_cast<int>(ms));
    return out;
}

} // namespace

LogWriter::LogWriter(LogFormat format, std::FILE* out) : format_(format), out_(out) {}

std::string LogWriter::format(const LogEvent& e) const {
    if (format_ == LogFormat::kText) {
        if (e.session != 0)
            return "session " + std::to_string(e.session) + " (" + e.peer + "): " + e.message;
        return e.source + ": " + e.message;
    }
    nlohmann::ordered_json j;
    j["time"] = utcNow();
    j["level"] = levelName(e.level);
    j["event"] = e.event;
    j["source"] = e.source;
    if (e.session != 0) {
        j["session"] = e.session;
        j["peer"] = e.peer;
    }
    j["message"] = e.message;
    for (const LogEvent::Field& f : e.fields) {
        if (f.numeric)
            j[f.key] = nlohmann::json::parse(f.value, nullptr, false);
        else
            j[f.key] = f.value;
    }
    // invalid UTF-8 (a peer's bytes in a message) is replaced, never thrown on
    return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

void LogWriter::write(const LogEvent& event) {
    const std::string line = format(event) + "\n";
    const std::lock_guard<std::mutex> lock(mutex_);
    std::fwrite(line.data(), 1, line.size(), out_);
    std::fflush(out_);
}

void LogWriter::info(
    const std::string& event, const std::string& source, const std::string& message) {
    writePlain(LogLevel::kInfo, event, source, message);
}

void LogWriter::error(
    const std::string& event, const std::string& source, const std::string& message) {
    writePlain(LogLevel::kError, event, source, message);
}

void LogWriter::writePlain(
    LogLevel level,
    const std::string& event,
    const std::string& source,
    const std::string& message) {
    LogEvent e;
    e.level = level;
    e.event = event;
    e.source = source;
    e.message = message;
    write(e);
}

} // namespace terrain::server
