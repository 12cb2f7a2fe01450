#include <terrain/render/frame_pacer.h>

#include <chrono>

namespace terrain::render {

void FramePacer::frameDone(const GlApi& gl) {
    GLsync& slot = fences_[next_];
    if (slot != nullptr) {
        // the frame kFramesInFlight back must be done before this one queues behind it
        const auto start = std::chrono::steady_clock::now();
        while (gl.ClientWaitSync(slot, GL_SYNC_FLUSH_COMMANDS_BIT, 1'000'000'000) ==
               GL_TIMEOUT_EXPIRED) {
        }
        waited_ns_ +=
            static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                           std::chrono::steady_clock::now() - start)
                                           .count());
        gl.DeleteSync(slot);
    }
    slot = gl.FenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    gl.Flush();
    next_ = (next_ + 1) % kFramesInFlight;
}

void FramePacer::release(const GlApi& gl) {
    for (GLsync& f : fences_) {
        if (f != nullptr)
            gl.DeleteSync(f);
        f = nullptr;
    }
}

} // namespace terrain::render
