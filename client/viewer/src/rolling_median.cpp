#include <terrain/viewer/rolling_median.h>

#include <algorithm>

namespace terrain::viewer {

void RollingMedian::push(double sample) {
    if (samples_.size() < window_) {
        samples_.push_back(sample);
        return;
    }
    samples_[next_] = sample;
    next_ = (next_ + 1) % window_;
}

double RollingMedian::median() const {
    return medianOf(samples_);
}

double medianOf(std::vector<double> values) {
    if (values.empty())
        return 0.0;
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
    std::nth_element(values.begin(), middle, values.end());
    return *middle;
}

} // namespace terrain::viewer
