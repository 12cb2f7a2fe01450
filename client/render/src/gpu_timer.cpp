#include <terrain/render/gpu_timer.h>

namespace terrain::render {

GpuTimer::GpuTimer(const GlApi& gl) : gl_(gl) {
    gl_.GenQueries(static_cast<GLsizei>(kQueries), queries_.data());
}

void GpuTimer::release() {
    if (queries_[0] != 0)
        gl_.DeleteQueries(static_cast<GLsizei>(kQueries), queries_.data());
    queries_.fill(0);
}

void GpuTimer::begin() {
    if (in_flight_ == kQueries) {
        ++skipped_; // every query still out: this frame goes untimed rather than wait
        return;
    }
    gl_.BeginQuery(GL_TIME_ELAPSED, queries_[next_]);
    began_[next_] = std::chrono::steady_clock::now();
    running_ = true;
}

void GpuTimer::end() {
    if (!running_)
        return;
    gl_.EndQuery(GL_TIME_ELAPSED);
    running_ = false;
    pending_[next_] = true;
    next_ = (next_ + 1) % kQueries;
    ++in_flight_;
}

std::size_t GpuTimer::collect(std::array<double, kQueries>& out) {
    std::size_t n = 0;
    while (in_flight_ > 0) {
        const unsigned q = queries_[oldest_];
        GLint ready = 0;
        gl_.GetQueryObjectiv(q, GL_QUERY_RESULT_AVAILABLE, &ready);
        if (ready == 0)
            break; // later ones finish later
        GLuint64 ns = 0;
        gl_.GetQueryObjectui64v(q, GL_QUERY_RESULT, &ns);
        const double ms = static_cast<double>(ns) * 1e-6;
        const double since = std::chrono::duration<double, std::milli>(
                                 std::chrono::steady_clock::now() - began_[oldest_])
                                 .count();
        pending_[oldest_] = false;
        oldest_ = (oldest_ + 1) % kQueries;
        --in_flight_;
        if (ms > since) {
            ++invalid_;
            continue;
        }
        out[n++] = ms;
        latest_ = ms;
    }
    return n;
}

} // namespace terrain::render
