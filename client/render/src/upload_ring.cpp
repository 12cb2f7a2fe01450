#include <terrain/render/upload_ring.h>

#include <algorithm>
#include <chrono>
#include <cstring>

namespace terrain::render {

namespace {
constexpr GLbitfield kPersistentFlags =
    GL_MAP_WRITE_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;

bool signalled(const GlApi& gl, GLsync fence) {
    const GLenum s = gl.ClientWaitSync(fence, 0, 0);
    return s == GL_ALREADY_SIGNALED || s == GL_CONDITION_SATISFIED;
}
} // namespace

const char* toString(UploadPath path) {
    switch (path) {
    case UploadPath::kPersistent:
        return "persistent";
    case UploadPath::kMapRange:
        return "map-range";
    default:
        return "auto";
    }
}

Result<UploadPath> parseUploadPath(const std::string& name) {
    if (name == "auto")
        return UploadPath::kAuto;
    if (name == "persistent")
        return UploadPath::kPersistent;
    if (name == "map-range")
        return UploadPath::kMapRange;
    return makeError(
        ErrorCode::kOutOfRange,
        "upload path must be 'auto', 'persistent' or 'map-range', got '" + name + "'");
}

UploadRing::UploadRing(const GlApi& gl, UploadPath path, std::uint64_t bytes) : gl_(gl) {
    const bool storage = gl.BufferStorage != nullptr &&
                         (gl.version() >= 44 || gl.hasExtension("GL_ARB_buffer_storage"));
    path_ = (path == UploadPath::kAuto || path == UploadPath::kPersistent) && storage
                ? UploadPath::kPersistent
                : UploadPath::kMapRange;
    allocate(std::max(bytes, kMinBytes));
}

void UploadRing::allocate(std::uint64_t bytes) {
    release();
    size_ = bytes;
    head_ = 0;
    gl_.GenBuffers(1, &ring_);
    gl_.BindBuffer(GL_COPY_READ_BUFFER, ring_);
    const auto size = static_cast<GLsizeiptr>(size_);
    if (path_ == UploadPath::kPersistent) {
        gl_.BufferStorage(GL_COPY_READ_BUFFER, size, nullptr, kPersistentFlags);
        mapped_ = gl_.MapBufferRange(GL_COPY_READ_BUFFER, 0, size, kPersistentFlags);
        if (mapped_ == nullptr) {
            // a driver that offers buffer storage but will not map it: the plain path
            gl_.DeleteBuffers(1, &ring_);
            ring_ = 0;
            path_ = UploadPath::kMapRange;
            allocate(bytes);
        }
    } else {
        gl_.BufferData(GL_COPY_READ_BUFFER, size, nullptr, GL_STREAM_DRAW);
    }
}

void UploadRing::release() {
    for (Region& r : busy_)
        gl_.DeleteSync(r.fence); // copies still reading the old ring keep it alive in the GL
    busy_.clear();
    if (ring_ != 0) {
        if (mapped_ != nullptr) {
            gl_.BindBuffer(GL_COPY_READ_BUFFER, ring_);
            gl_.UnmapBuffer(GL_COPY_READ_BUFFER);
            mapped_ = nullptr;
        }
        gl_.DeleteBuffers(1, &ring_);
        ring_ = 0;
    }
}

void UploadRing::stage(
    unsigned buffer, std::uint64_t offset, const void* data, std::uint64_t bytes) {
    if (bytes == 0)
        return;
    const std::uint64_t at = staged_.size();
    staged_.resize(at + bytes);
    std::memcpy(staged_.data() + at, data, bytes);
    copies_.push_back(Copy{0, buffer, at, offset, bytes});
}

void UploadRing::moveBuffer(unsigned from, unsigned to, std::uint64_t bytes) {
    if (bytes > 0)
        copies_.push_back(Copy{from, to, 0, 0, bytes});
    retired_.push_back(from);
}

std::uint64_t UploadRing::reserve(std::uint64_t bytes) {
    if (bytes > size_) {
        std::uint64_t grown = size_;
        while (grown < bytes)
            grown *= 2;
        allocate(grown);
        ++stats_.grown;
    }
    std::uint64_t at = head_ + bytes <= size_ ? head_ : 0;
    // the newest region the new one overlaps: the GPU finishes copies in order, so once it is
    // done every older one is
    const auto overlaps = [&](const Region& r) { return r.begin < at + bytes && at < r.end; };
    auto last = std::find_if(busy_.rbegin(), busy_.rend(), overlaps);
    if (last != busy_.rend() && !signalled(gl_, last->fence)) {
        if (size_ * 2 <= kMaxBytes) {
            // still being read: a bigger ring rather than a wait
            allocate(size_ * 2);
            ++stats_.grown;
            at = 0;
            last = busy_.rend();
        } else {
            const auto start = std::chrono::steady_clock::now();
            while (gl_.ClientWaitSync(last->fence, GL_SYNC_FLUSH_COMMANDS_BIT, 1'000'000'000) ==
                   GL_TIMEOUT_EXPIRED) {
            }
            ++stats_.waits;
            stats_.wait_ns +=
                static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                               std::chrono::steady_clock::now() - start)
                                               .count());
        }
    }
    if (last != busy_.rend()) {
        const auto done = busy_.rend() - last; // regions up to and including it
        for (auto i = busy_.begin(); i != busy_.begin() + done; ++i)
            gl_.DeleteSync(i->fence);
        busy_.erase(busy_.begin(), busy_.begin() + done);
    }
    head_ = at + bytes;
    return at;
}

bool UploadRing::write(std::uint64_t at) {
    const std::uint64_t n = staged_.size();
    if (mapped_ != nullptr) {
        std::memcpy(static_cast<unsigned char*>(mapped_) + at, staged_.data(), n);
        return true;
    }
    gl_.BindBuffer(GL_COPY_READ_BUFFER, ring_);
    // the fences say no copy reads this region any more: no need for the GL to wait
    void* p = gl_.MapBufferRange(
        GL_COPY_READ_BUFFER, static_cast<GLintptr>(at), static_cast<GLsizeiptr>(n),
        GL_MAP_WRITE_BIT | GL_MAP_INVALIDATE_RANGE_BIT | GL_MAP_UNSYNCHRONIZED_BIT);
    if (p != nullptr) {
        std::memcpy(p, staged_.data(), n);
        if (gl_.UnmapBuffer(GL_COPY_READ_BUFFER) == GL_TRUE)
            return true;
    }
    // no mapping, or its contents were lost (a mode switch, say): the plain call is exact
    ++stats_.map_retries;
    gl_.BufferSubData(
        GL_COPY_READ_BUFFER, static_cast<GLintptr>(at), static_cast<GLsizeiptr>(n), staged_.data());
    return false;
}

void UploadRing::flush() {
    if (copies_.empty() && retired_.empty())
        return;
    const std::uint64_t n = staged_.size();
    std::uint64_t at = 0;
    if (n > 0) {
        at = reserve(n);
        write(at);
        stats_.bytes += n;
        ++stats_.flushes;
    }
    unsigned read = 0;
    unsigned written = 0;
    for (const Copy& c : copies_) {
        const unsigned from = c.from == 0 ? ring_ : c.from;
        if (from != read) {
            gl_.BindBuffer(GL_COPY_READ_BUFFER, from);
            read = from;
        }
        if (c.to != written) {
            gl_.BindBuffer(GL_COPY_WRITE_BUFFER, c.to);
            written = c.to;
        }
        const std::uint64_t source = c.from == 0 ? at + c.source : c.source;
        gl_.CopyBufferSubData(
            GL_COPY_READ_BUFFER, GL_COPY_WRITE_BUFFER, static_cast<GLintptr>(source),
            static_cast<GLintptr>(c.target), static_cast<GLsizeiptr>(c.bytes));
        ++stats_.copies;
        if (c.from != 0)
            stats_.copy_bytes += c.bytes;
    }
    if (n > 0)
        busy_.push_back(Region{at, at + n, gl_.FenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0)});
    if (!retired_.empty())
        gl_.DeleteBuffers(static_cast<GLsizei>(retired_.size()), retired_.data());
    retired_.clear();
    staged_.clear();
    copies_.clear();
}

} // namespace terrain::render
