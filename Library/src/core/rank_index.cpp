// CrowdHealth — how many of a set of numbers lie below a given one (see rank_index.h).
#include "crowdhealth/core/rank_index.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ch {

void RankIndex::assign(const std::vector<double>& values) {
    const std::span<const double> whole(values);
    assign(std::span<const std::span<const double>>(&whole, 1));
}

void RankIndex::assign(std::span<const std::span<const double>> parts) {
    std::size_t n = 0;
    for (const auto& part : parts) n += part.size();
    sorted_.resize(n);
    if (n == 0) return;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& part : parts)
        for (const double x : part)
            if (std::isfinite(x)) {
                lo = std::min(lo, x);
                hi = std::max(hi, x);
            }
    const std::size_t buckets = n;
    last_ = static_cast<double>(buckets - 1);
    lo_ = lo <= hi ? lo : 0;
    scale_ = lo < hi ? static_cast<double>(buckets) / (hi - lo) : 0;  // may be +∞ (see bucket())
    // Counting sort into the buckets: each bucket's size, then the end of each bucket, then every
    // value put in place from its bucket's end down (start_[b] ends at the bucket's first place).
    start_.assign(buckets + 1, 0);
    bucketOf_.resize(n);
    std::size_t i = 0;
    for (const auto& part : parts)
        for (const double x : part) {
            const std::size_t b = bucket(x);
            bucketOf_[i++] = static_cast<std::uint32_t>(b);
            ++start_[b];
        }
    std::uint32_t end = 0;
    for (std::size_t b = 0; b < buckets; ++b) start_[b] = end += start_[b];
    start_[buckets] = static_cast<std::uint32_t>(n);
    i = 0;
    for (const auto& part : parts)
        for (const double x : part) sorted_[--start_[bucketOf_[i++]]] = x;
    for (std::size_t b = 0; b < buckets; ++b)
        if (static_cast<std::ptrdiff_t>(start_[b + 1] - start_[b]) > kSmall)
            std::sort(sorted_.data() + start_[b], sorted_.data() + start_[b + 1]);
}

}  // namespace ch
