// CrowdHealth — memory for large, long-lived buffers (see big_alloc.h).
#include "crowdhealth/core/big_alloc.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>

#if defined(__linux__)
#include <sys/mman.h>
#define CH_BIG_ALLOC_MMAP 1
#if defined(__GLIBC__)
#include <malloc.h>
#include <unistd.h>
#include <vector>
#define CH_BIG_ALLOC_HEAP 1
#endif
#endif

namespace ch {

namespace {

constexpr std::size_t kSmallAlign = 64;  // a cache line
[[maybe_unused]] constexpr std::size_t kHeapOnHugePagesFrom = 2 * kHugePage;
[[maybe_unused]] constexpr std::size_t kHeapPadMax = std::size_t{512} << 20;

#ifdef CH_BIG_ALLOC_MMAP
std::size_t roundUp(std::size_t bytes, std::size_t to) { return (bytes + to - 1) / to * to; }
#endif

}  // namespace

bool bigAllocateUsesHugePages(std::size_t bytes) {
#ifdef CH_BIG_ALLOC_MMAP
    return bytes >= kHugePage;
#else
    (void)bytes;
    return false;
#endif
}

void* bigAllocate(std::size_t bytes) {
#ifdef CH_BIG_ALLOC_MMAP
    if (bigAllocateUsesHugePages(bytes)) {
        // Map one huge page more than needed, keep the 2-MiB-aligned part: the kernel gives huge
        // pages only to aligned 2-MiB ranges of the mapping.
        const std::size_t size = roundUp(bytes, kHugePage);
        if (size < bytes || size + kHugePage < size) throw std::bad_alloc();
        void* raw = mmap(nullptr, size + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (raw == MAP_FAILED) throw std::bad_alloc();
        const std::uintptr_t begin = reinterpret_cast<std::uintptr_t>(raw);
        const std::uintptr_t aligned = (begin + kHugePage - 1) & ~(std::uintptr_t{kHugePage} - 1);
        if (aligned > begin) munmap(raw, aligned - begin);
        const std::size_t tail = begin + size + kHugePage - (aligned + size);
        if (tail > 0) munmap(reinterpret_cast<void*>(aligned + size), tail);
        void* p = reinterpret_cast<void*>(aligned);
        madvise(p, size, MADV_HUGEPAGE);  // a hint: without THP the pages are small, no error
        return p;
    }
#endif
    return ::operator new(bytes == 0 ? 1 : bytes, std::align_val_t{kSmallAlign});
}

void bigFree(void* p, std::size_t bytes) noexcept {
    if (p == nullptr) return;
#ifdef CH_BIG_ALLOC_MMAP
    if (bigAllocateUsesHugePages(bytes)) {
        munmap(p, roundUp(bytes, kHugePage));
        return;
    }
#endif
    ::operator delete(p, std::align_val_t{kSmallAlign});
}

bool heapOnHugePages(std::size_t bytes) {
#ifdef CH_BIG_ALLOC_HEAP
    static bool done = false;  // called from the main thread before any other allocates
    if (done || bytes < kHeapOnHugePagesFrom) return false;
    done = true;
    const std::size_t pad = roundUp(std::min(bytes, kHeapPadMax), kHugePage);
    // Blocks up to half the pad come from the heap too (the file's text, the agents' specs),
    // not from mmap: M_TOP_PAD turns off glibc's sliding mmap threshold, which would do that.
    if (mallopt(M_TOP_PAD, static_cast<int>(pad)) != 1) return false;
    mallopt(M_MMAP_THRESHOLD, static_cast<int>(std::min<std::size_t>(pad / 2, std::size_t{32} << 20)));
    const std::uintptr_t before = reinterpret_cast<std::uintptr_t>(sbrk(0));
    // Blocks of kProbe until malloc extends the heap (by what it needs plus `pad`), then freed
    // again: the top of the heap keeps `pad` bytes no page of which has been touched (free()
    // trims only beyond M_TOP_PAD). Their aligned part is marked for huge pages.
    constexpr std::size_t kProbe = std::size_t{64} << 10;
    std::vector<void*> probes;
    probes.reserve(pad / 2 / kProbe);
    while (reinterpret_cast<std::uintptr_t>(sbrk(0)) == before && probes.size() < pad / 2 / kProbe)
        probes.push_back(std::malloc(kProbe));
    for (void* p : probes) std::free(p);
    const std::uintptr_t after = reinterpret_cast<std::uintptr_t>(sbrk(0));
    // Past the pages the probe's and the top's headers touched, to whole huge pages.
    const std::uintptr_t lo = (before + 2 * kProbe + kHugePage - 1) & ~(std::uintptr_t{kHugePage} - 1);
    const std::uintptr_t hi = after & ~(std::uintptr_t{kHugePage} - 1);
    if (hi <= lo) return false;  // no heap from brk (e.g. glibc fell back to mmap)
    return madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE) == 0;
#else
    (void)bytes;
    return false;
#endif
}

}  // namespace ch
