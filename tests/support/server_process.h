#pragma once

// A real terrain-server process for tests that need one (kill -9, signals, its flags and main):
// `terrain-server --token-secret <the test secret> serve --bind 127.0.0.1 --port 0 <args>`,
// stdout and stderr to `log`. Callers wait for its port file and reap it with waitpid.

#include "support/loopback.h"

#include <sys/types.h>
#include <unistd.h>

#include <cstdio>
#include <string>
#include <vector>

namespace terrain::testing {

/// Forks and execs TERRAIN_SERVER_BIN; returns the child's pid (-1 if fork failed).
inline pid_t
spawnServerProcess(const std::vector<std::string>& serve_args, const std::string& log) {
    const std::string secret(testSecret().begin(), testSecret().end());
    std::vector<std::string> args = {TERRAIN_SERVER_BIN, "--token-secret", secret,   "serve",
                                     "--bind",           "127.0.0.1",      "--port", "0"};
    args.insert(args.end(), serve_args.begin(), serve_args.end());
    std::vector<char*> argv;
    for (std::string& a : args)
        argv.push_back(a.data());
    argv.push_back(nullptr);
    const pid_t pid = fork();
    if (pid == 0) {
        std::freopen(log.c_str(), "w", stdout);
        std::freopen(log.c_str(), "a", stderr);
        execv(TERRAIN_SERVER_BIN, argv.data());
        _exit(127);
    }
    return pid;
}

} // namespace terrain::testing
