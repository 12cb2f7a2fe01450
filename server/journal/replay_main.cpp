// terrain-replay: offline check of a journal directory (verifyJournal()): replays every record
// from the oldest snapshot, checks world hashes, seq continuity and later snapshots, and prints a
// summary. Exit 0 when the journal is sound, 1 when a rule is broken, 2 for bad arguments.

#include <terrain/journal/journal.h>

#include <CLI/CLI.hpp>

#include <cinttypes>
#include <cstdio>
#include <string>

namespace {

std::string jsonString(const std::string& text) {
    std::string out = "\"";
    for (const char c : text) {
        if (c == '"' || c == '\\') {
            out += '\\';
            out += c;
        } else if (static_cast<unsigned char>(c) < 0x20) {
            char escaped[8];
            std::snprintf(escaped, sizeof escaped, "\\u%04x", static_cast<unsigned>(c));
            out += escaped;
        } else {
            out += c;
        }
    }
    return out + "\"";
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"terrain-replay: verify a terrain journal directory offline"};
    std::string dir;
    bool json = false;
    app.add_option("data-dir", dir, "journal directory (snapshots and segments)")->required();
    app.add_flag("--json", json, "print the report or the error as one JSON object");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help is a ParseError too, with exit code 0
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;
    }

    const auto report = terrain::journal::verifyJournal(dir);
    if (!report) {
        const terrain::Error& e = report.error();
        if (json)
            std::printf(
                "{\"ok\":false,\"code\":%s,\"error\":%s}\n",
                jsonString(terrain::toString(e.code)).c_str(), jsonString(e.message).c_str());
        else
            std::fprintf(
                stderr, "terrain-replay: %s: %s (%s)\n", dir.c_str(), e.message.c_str(),
                terrain::toString(e.code));
        return 1;
    }
    const auto& r = *report;
    if (json) {
        std::printf(
            "{\"ok\":true,\"records\":%zu,\"base_seq\":%" PRIu64 ",\"last_seq\":%" PRIu64
            ",\"segments\":%zu,\"snapshots_checked\":%zu,\"final_world_hash\":\"%016" PRIx64
            "\",\"torn_bytes\":%zu}\n",
            r.records_checked, r.base_seq, r.last_seq, r.segments_checked, r.snapshots_checked,
            r.final_hash, r.torn_bytes);
        return 0;
    }
    std::printf("journal    : %s\n", dir.c_str());
    std::printf("records    : %zu", r.records_checked);
    if (r.records_checked > 0)
        std::printf(" (seq %" PRIu64 "..%" PRIu64 ")", r.base_seq + 1, r.last_seq);
    std::printf("\nbase       : snapshot at seq %" PRIu64 "\n", r.base_seq);
    std::printf("segments   : %zu\n", r.segments_checked);
    std::printf("snapshots  : %zu checked\n", r.snapshots_checked);
    std::printf("world hash : %016" PRIx64 " at seq %" PRIu64 "\n", r.final_hash, r.last_seq);
    std::printf(
        "torn bytes : %zu%s\n", r.torn_bytes,
        r.torn_bytes > 0 ? " (at the end of the newest segment; recovery drops them)" : "");
    return 0;
}
