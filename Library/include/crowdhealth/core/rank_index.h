// CrowdHealth — how many of a set of numbers lie below a given one, for sets rebuilt every step.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace ch {

/// A set of doubles that answers countBelow(x): the number of its values v with v < x, which is
/// what std::lower_bound(x) returns on the values sorted. The quickest exit rule asks it, for a
/// few hundred people each step, how many of the people heading to an exit are nearer to it.
///
/// assign() puts the values into buckets of equal width between the smallest and the largest
/// finite value (about one value per bucket; +∞ goes to the last): three passes over the values,
/// where a full sort takes many. Bucket numbers never decrease as values grow, so every value of
/// a lower bucket is below x and none of a higher one is: countBelow(x) reads where x's bucket
/// starts and counts the values below x in that one bucket. Exact whatever the values' spread:
/// a bucket of more than a few values (values crowded together) is sorted and searched instead.
/// Values must not be NaN (countBelow(NaN) is 0, as std::lower_bound gives).
class RankIndex {
public:
    /// Replaces the set by `values` (any order). Storage is kept from call to call.
    void assign(const std::vector<double>& values);
    /// Replaces the set by the values of every part together (parts gathered apart, e.g. one per
    /// thread): the same counts as assign() of their concatenation, in any order of the parts.
    void assign(std::span<const std::span<const double>> parts);
    /// Number of values v with v < x.
    std::size_t countBelow(double x) const {
        if (sorted_.empty() || !(x == x)) return 0;
        const std::size_t b = bucket(x);
        const double* first = sorted_.data() + start_[b];
        const double* last = sorted_.data() + start_[b + 1];
        if (last - first > kSmall) return static_cast<std::size_t>(std::lower_bound(first, last, x) - sorted_.data());
        std::size_t below = start_[b];  // a bucket holds about one value, in any order
        for (const double* p = first; p != last; ++p) below += *p < x ? 1 : 0;
        return below;
    }
    std::size_t size() const { return sorted_.size(); }

private:
    static constexpr std::ptrdiff_t kSmall = 8;  ///< buckets of more values are sorted and searched

    /// x's bucket: 0 below the smallest finite value, the last from the largest finite value up
    /// (and for +∞). Non-decreasing in x, which is all countBelow needs: x − lo and its product
    /// with scale ≥ 0 round monotonically, and truncation keeps the order. The product is NaN in
    /// two cases, both sent to bucket 0 without breaking the order: a scale of 0 (every finite
    /// value the same, so every finite x is in bucket 0 anyway) with x = ±∞, and an infinite scale
    /// (a spread too small to divide by) with x = lo (every x below lo is in bucket 0 too, every x
    /// above it in the last).
    std::size_t bucket(double x) const {
        const double s = (x - lo_) * scale_;
        if (s < last_) return s > 0 ? static_cast<std::size_t>(s) : 0;
        return s >= last_ ? static_cast<std::size_t>(last_) : 0;  // NaN: ±∞·0 or 0·∞
    }

    std::vector<double> sorted_;           ///< the values bucket by bucket (a bucket of more than kSmall sorted)
    std::vector<std::uint32_t> start_;   ///< per bucket its first value in sorted_, then size()
    std::vector<std::uint32_t> bucketOf_;  ///< assign()'s scratch: each value's bucket
    double lo_ = 0, scale_ = 0;
    double last_ = 0;  ///< the last bucket's number, as a double (one bucket per value)
};

}  // namespace ch
