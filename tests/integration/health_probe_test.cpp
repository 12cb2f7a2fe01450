// `terrain-server health`, the probe a container's HEALTHCHECK runs, against a live server, a
// closed port and a bad address: what it prints and its exit code.

#include "support/server_process.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

namespace terrain::testing {
namespace {

namespace fs = std::filesystem;

struct ProbeResult {
    int code = -1;
    std::string out;
};

ProbeResult probe(const std::string& connect) {
    const std::string command =
        std::string(TERRAIN_SERVER_BIN) + " health --connect " + connect + " 2>&1";
    ProbeResult r;
    FILE* pipe = popen(command.c_str(), "r");
    if (pipe == nullptr)
        return r;
    char buf[256];
    while (std::fgets(buf, sizeof buf, pipe) != nullptr)
        r.out += buf;
    const int status = pclose(pipe);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

TEST(HealthProbe, SaysOkWithTheWorldFromALiveServerAndFailsOnAClosedPortOrABadAddress) {
    const fs::path dir = fs::temp_directory_path() / ("terrain-health-" + std::to_string(getpid()));
    fs::create_directories(dir);
    const fs::path port_file = dir / "port";
    const pid_t pid = spawnServerProcess(
        {"--no-journal", "--size", "129", "--port-file", port_file.string()},
        (dir / "server.log").string());
    ASSERT_GT(pid, 0);
    std::string port;
    for (int i = 0; i < 300 && port.empty(); ++i) {
        std::ifstream in(port_file);
        std::getline(in, port);
        if (port.empty())
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ASSERT_FALSE(port.empty()) << "the server did not start";

    const ProbeResult live = probe("127.0.0.1:" + port);
    EXPECT_EQ(live.code, 0) << live.out;
    EXPECT_NE(live.out.find("health: ok: serving, seq 0, hash "), std::string::npos) << live.out;

    kill(pid, SIGTERM);
    int status = 0;
    waitpid(pid, &status, 0);
    const ProbeResult closed = probe("127.0.0.1:" + port);
    EXPECT_EQ(closed.code, 1) << closed.out;
    EXPECT_NE(closed.out.find("health: FAIL: cannot connect"), std::string::npos) << closed.out;

    const ProbeResult bad = probe("nonsense");
    EXPECT_EQ(bad.code, 2) << bad.out;
    EXPECT_NE(bad.out.find("--connect must be host:port"), std::string::npos) << bad.out;
    // a port that does not resolve is a failed probe with its reason, not an abort
    const ProbeResult unresolved = probe("127.0.0.1:notaport");
    EXPECT_EQ(unresolved.code, 1) << unresolved.out;
    EXPECT_NE(
        unresolved.out.find("health: FAIL: cannot resolve 127.0.0.1:notaport"), std::string::npos)
        << unresolved.out;
    fs::remove_all(dir);
}

} // namespace
} // namespace terrain::testing
