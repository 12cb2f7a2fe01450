// The server's log lines: the text form people read (unchanged by the JSON option), and JSON
// Lines that a log pipeline parses, one object per event, whatever bytes a peer put in them.

#include <terrain/server/log_writer.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace terrain::server {
namespace {

LogEvent closeEvent(std::string message) {
    LogEvent e;
    e.event = "session.close";
    e.session = 3;
    e.peer = "10.0.0.7:51234";
    e.message = std::move(message);
    e.fields = {{"reason", "REASON_FLOODING", false}, {"seq", "42", true}};
    return e;
}

TEST(LogWriter, TextLinesReadAsBefore) {
    const LogWriter text(LogFormat::kText);
    EXPECT_EQ(
        text.format(closeEvent("closing: flood")), "session 3 (10.0.0.7:51234): closing: flood");
    LogEvent plain;
    plain.source = "journal";
    plain.message = "new world in /data";
    EXPECT_EQ(text.format(plain), "journal: new world in /data");
}

TEST(LogWriter, JsonLinesCarryTheSessionAndTheEventsFields) {
    const LogWriter json(LogFormat::kJson);
    const std::string line = json.format(closeEvent("closing: flood"));
    EXPECT_EQ(line.find('\n'), std::string::npos);
    const auto j = nlohmann::json::parse(line);
    EXPECT_EQ(j["event"], "session.close");
    EXPECT_EQ(j["level"], "info");
    EXPECT_EQ(j["session"], 3);
    EXPECT_EQ(j["peer"], "10.0.0.7:51234");
    EXPECT_EQ(j["reason"], "REASON_FLOODING");
    EXPECT_EQ(j["seq"], 42);
    EXPECT_EQ(j["message"], "closing: flood");
    EXPECT_EQ(j["time"].get<std::string>().size(), 24u); // 2026-12-03T15:06:16.123Z
    // a message with a newline, quotes and invalid UTF-8 (a peer's bytes): still one object
    const std::string hostile = json.format(closeEvent("a\nb \"c\" \xff\xfe"));
    EXPECT_EQ(hostile.find('\n'), std::string::npos);
    EXPECT_TRUE(nlohmann::json::accept(hostile));
}

} // namespace
} // namespace terrain::server
