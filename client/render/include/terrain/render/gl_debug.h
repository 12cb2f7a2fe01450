#pragma once

// KHR_debug output (core in GL 4.3): every message the driver sends about the calls made in a
// context (errors, undefined behaviour, performance warnings such as a stall on a buffer in
// use), logged and counted, errors apart. Debug contexts (the bot's and the viewer's
// --gl-debug, the render tests) attach one; a context without KHR_debug says so instead.
// Synchronous output: a message arrives inside the call that caused it.

#include <terrain/render/gl_api.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace terrain::render {

class GlDebugLog {
  public:
    /// Where each message goes as it arrives ("GL <severity> <type> <id>: <text>"); stderr by
    /// default.
    using Sink = std::function<void(const std::string& line)>;

    /// Turns debug output on in the current context and routes it here. False if the context
    /// lacks KHR_debug (nothing is then reported).
    bool attach(const GlApi& gl);
    bool attached() const { return attached_; }
    void setSink(Sink sink) { sink_ = std::move(sink); }

    /// GL_DEBUG_TYPE_ERROR messages since attach(): a call the GL refused (and ignored).
    std::uint64_t errors() const { return errors_; }
    /// Every message, errors included.
    std::uint64_t messages() const { return messages_; }
    /// The first kKeptLines messages, formatted as sent to the sink.
    const std::vector<std::string>& kept() const { return kept_; }
    static constexpr std::size_t kKeptLines = 64;

    /// Called by the GL (public for the C callback).
    void receive(
        unsigned source, unsigned type, unsigned id, unsigned severity, const std::string& text);

  private:
    bool attached_ = false;
    std::uint64_t errors_ = 0;
    std::uint64_t messages_ = 0;
    std::vector<std::string> kept_;
    Sink sink_;
};

} // namespace terrain::render
