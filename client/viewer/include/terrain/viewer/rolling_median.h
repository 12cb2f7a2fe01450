#pragma once

// The median of the last N samples (frame times on the overlay): robust to the odd slow frame
// (a crater's re-tessellation, a snapshot) that an average would smear over a second.

#include <cstddef>
#include <vector>

namespace terrain::viewer {

class RollingMedian {
  public:
    explicit RollingMedian(std::size_t window = 60) : window_(window == 0 ? 1 : window) {}

    void push(double sample);
    /// 0 before the first sample.
    double median() const;
    std::size_t size() const { return samples_.size(); }

  private:
    std::size_t window_;
    std::size_t next_ = 0; ///< oldest slot once full
    std::vector<double> samples_;
};

/// Median of `values` (the upper middle for an even count); 0 when empty.
double medianOf(std::vector<double> values);

} // namespace terrain::viewer
