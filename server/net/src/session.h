#pragma once

// The Asio shell of one client session: a TCP socket and a timer around a SessionMachine. It
// reads into the machine, writes what the machine queues (gathered, one write at a time), and
// arms the machine's deadlines. Lives on the server's io thread, kept alive by its own pending
// operations (shared_ptr).
//
// Closing never drops the goodbye: a socket closed with unread input sends a reset, and the
// peer's kernel then discards what the peer had not read, the Disconnect with it (a flood in one
// write). So once the machine stops reading, input is read and discarded; once it is done, the
// socket sends its FIN after the last frame and is closed when the peer closes its side, or
// after the close linger at most.

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
    /// Seconds on the monotonic clock every session's `now` comes from (the hub's timings too).
    static double now();

  private:
    void framesQueued() override;
    void setDeadline(double at) override;
    void stopReading() override;
    void closeLink() override;

    void readMore();
    void writeMore();
    /// Reads and discards until the peer closes or an error; then closes the socket.
    void drain();
    void closeSocket();

    ServerHub& hub_;
    asio::ip::tcp::socket socket_;
    int send_buffer_bytes_;
    std::shared_ptr<SessionMachine> machine_;
    asio::steady_timer timer_;
    std::vector<asio::const_buffer> gather_;
    bool reading_ = false;
    bool reading_stopped_ = false; ///< the machine reads no more: input is discarded
    bool closed_ = false;          ///< the machine is done with the link
    std::vector<std::uint8_t> discard_;
};

} // namespace terrain::server
