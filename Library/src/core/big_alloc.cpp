// CrowdHealth — memory for large, long-lived buffers (see big_alloc.h).
#include "crowdhealth/core/big_alloc.h"

#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#define CH_BIG_ALLOC_MMAP 1
#endif

namespace ch {

namespace {

constexpr std::size_t kSmallAlign = 64;  // a cache line

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

}  // namespace ch
