#pragma once

// What a swap chain does for a window, for offscreen contexts: present() submits the frame and
// lets the GPU work behind the CPU, waiting (on a fence) only while more than kFramesInFlight
// frames are queued. glFinish every frame instead made the CPU wait for each frame's GPU work.

#include <terrain/render/gl_api.h>

#include <array>
#include <cstdint>

namespace terrain::render {

class FramePacer {
  public:
    static constexpr std::size_t kFramesInFlight = 2;

    /// Flushes the frame's commands and fences them; returns once at most kFramesInFlight
    /// frames are unfinished.
    void frameDone(const GlApi& gl);
    /// Deletes the fences (the context current, before it goes).
    void release(const GlApi& gl);
    /// Nanoseconds frameDone() has spent waiting, all told.
    std::uint64_t waitedNanoseconds() const { return waited_ns_; }

  private:
    std::array<GLsync, kFramesInFlight> fences_{};
    std::size_t next_ = 0;
    std::uint64_t waited_ns_ = 0;
};

} // namespace terrain::render
