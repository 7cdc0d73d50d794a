// CrowdHealth — an exact radix sort of doubles (see radix_sort.h).
#include "crowdhealth/core/radix_sort.h"

#include <algorithm>
#include <bit>
#include <cstddef>

namespace ch {

void sortDoubles(std::vector<double>& v, std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& scratch) {
    const std::size_t n = v.size();
    if (n < 256) {
        std::sort(v.begin(), v.end());
        return;
    }
    constexpr std::uint64_t kSign = std::uint64_t{1} << 63;
    std::vector<std::uint64_t>& a = keys;
    std::vector<std::uint64_t>& b = scratch;
    a.resize(n);
    b.resize(n);
    // The key orders as the value: a negative value's bits all flipped (a larger magnitude gives a
    // smaller key), any other value's sign bit set (above every negative one).
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t bits = std::bit_cast<std::uint64_t>(v[i]);
        a[i] = (bits & kSign) ? ~bits : bits | kSign;
    }
    std::size_t count[8][256] = {};
    for (const std::uint64_t k : a)
        for (int d = 0; d < 8; ++d) ++count[d][(k >> (8 * d)) & 0xff];
    for (int d = 0; d < 8; ++d) {
        const int shift = 8 * d;
        std::size_t* c = count[d];
        if (c[(a[0] >> shift) & 0xff] == n) continue;  // every key has this byte: the pass keeps the order
        std::size_t sum = 0;
        for (int k = 0; k < 256; ++k) {
            const std::size_t here = c[k];
            c[k] = sum;
            sum += here;
        }
        // Stable: keys with the same byte keep the order of the previous passes.
        for (const std::uint64_t k : a) b[c[(k >> shift) & 0xff]++] = k;
        a.swap(b);
    }
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t k = a[i];
        v[i] = std::bit_cast<double>((k & kSign) ? k & ~kSign : ~k);
    }
}

}  // namespace ch
