#pragma once

// The Asio shell of one client session: a TCP socket and a timer around a SessionMachine. It
// reads into the machine, writes what the machine queues (gathered, one write at a time), and
// arms the machine's deadlines. Lives on the server's io thread, kept alive by its own pending
// operations (shared_ptr).

#include <terrain/server/server_hub.h>
#include <terrain/server/session_machine.h>

#include <asio.hpp>
#include <memory>
#include <vector>

namespace terrain::server {

class Session : public std::enable_shared_from_this<Session>, private SessionLink {
  public:
    Session(ServerHub& hub, asio::ip::tcp::socket socket, int send_buffer_bytes);
    ~Session() override;

    /// Registers with the hub and starts reading.
    void start();

  private:
    void framesQueued() override;
    void setDeadline(double at) override;
    void stopReading() override;
    void closeLink() override;

    void readMore();
    void writeMore();
    static double now();

    ServerHub& hub_;
    asio::ip::tcp::socket socket_;
    int send_buffer_bytes_;
    std::shared_ptr<SessionMachine> machine_;
    asio::steady_timer timer_;
    std::vector<asio::const_buffer> gather_;
    bool reading_ = false;
    bool reading_stopped_ = false;
    bool closed_ = false;
};

} // namespace terrain::server
