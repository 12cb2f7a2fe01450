#pragma once

// A terrain-server process for the tests of the game client's public API, which link nothing of
// ours but libterrain_client.so (as a game does): the server runs as its own program, tokens
// come from `terrain-server token`, the world's seq and hash from `terrain-server health`.

#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

namespace terrain::testing {

class LiveServer {
  public:
    /// `terrain-server serve` on a loopback port of its choosing, a `size` map, with
    /// `serve_options` (no journal unless they say otherwise: its data dir is dataDir()).
    explicit LiveServer(int size = 257, std::vector<std::string> serve_options = {"--no-journal"}) {
        dir_ = std::filesystem::temp_directory_path() /
               ("terrain-api-" + std::to_string(getpid()) + "-" + std::to_string(++count()));
        std::filesystem::create_directories(dir_);
        const std::string port_file = (dir_ / "port").string();
        const std::string log = (dir_ / "server.log").string();
        std::vector<std::string> args = {
            TERRAIN_SERVER_BIN,
            "--token-secret",
            kSecret,
            "serve",
            "--bind",
            "127.0.0.1",
            "--port",
            "0",
            "--port-file",
            port_file,
            "--data-dir",
            dataDir(),
            "--size",
            std::to_string(size),
            "--deform-rate",
            "100000"};
        args.insert(args.end(), serve_options.begin(), serve_options.end());
        std::vector<char*> argv;
        for (std::string& a : args)
            argv.push_back(a.data());
        argv.push_back(nullptr);
        std::fflush(nullptr); // the child must not flush the parent's buffers again
        pid_ = fork();
        if (pid_ == 0) {
            std::freopen(log.c_str(), "w", stdout);
            std::freopen(log.c_str(), "a", stderr);
            execv(TERRAIN_SERVER_BIN, argv.data());
            _exit(127);
        }
        for (int i = 0; i < 3000 && port_ == 0; ++i) {
            std::ifstream in(port_file);
            int port = 0;
            if (in >> port && port > 0)
                port_ = static_cast<std::uint16_t>(port);
            else
                std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
    }
    ~LiveServer() {
        if (pid_ > 0) {
            kill(pid_, SIGTERM);
            int status = 0;
            waitpid(pid_, &status, 0);
        }
        std::error_code ignored;
        std::filesystem::remove_all(dir_, ignored);
    }
    LiveServer(const LiveServer&) = delete;
    LiveServer& operator=(const LiveServer&) = delete;

    /// The journal's directory, when the options keep one.
    std::string dataDir() const { return (dir_ / "data").string(); }

    /// 0 if the server did not start.
    std::uint16_t port() const { return port_; }

    /// A token `terrain-server token` mints for this server's secret.
    std::string token(int player, const char* role) const {
        return run(
            std::string(TERRAIN_SERVER_BIN) + " --token-secret " + kSecret + " token --player " +
            std::to_string(player) + " --role " + role);
    }

    struct World {
        std::uint64_t seq = 0;
        std::uint64_t hash = 0;
        bool ok = false;
    };
    /// The server's seq and world hash, from its health reply.
    World world() const {
        const std::string out =
            run(std::string(TERRAIN_SERVER_BIN) +
                " health --connect 127.0.0.1:" + std::to_string(port_));
        World w;
        unsigned long long seq = 0, hash = 0;
        const auto at = out.find("seq ");
        if (at != std::string::npos &&
            std::sscanf(out.c_str() + at, "seq %llu, hash %llx", &seq, &hash) == 2) {
            w = {seq, hash, true};
        }
        return w;
    }

  private:
    static constexpr const char* kSecret = "api-test-secret-0123456789";
    static int& count() {
        static int n = 0;
        return n;
    }
    static std::string run(const std::string& command) {
        std::string out;
        if (FILE* p = popen(command.c_str(), "r")) {
            char buffer[512];
            while (std::fgets(buffer, sizeof buffer, p) != nullptr)
                out += buffer;
            pclose(p);
        }
        while (!out.empty() && (out.back() == '\n' || out.back() == '\r'))
            out.pop_back();
        return out;
    }

    std::filesystem::path dir_;
    pid_t pid_ = -1;
    std::uint16_t port_ = 0;
};

} // namespace terrain::testing
