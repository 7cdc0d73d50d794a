// CrowdHealth — memory for large, long-lived buffers (issue 20: the process's fixed cost).
//
// The first write to each fresh 4-KiB page costs a page fault: ~1 µs on bare metal, ~10 µs on
// some virtual machines (Firecracker), where a 10k-agent run spent a third of its start-up on
// them. A 2-MiB transparent huge page costs one fault for 512 such pages. Buffers of at least
// kHugePage bytes are therefore taken from whole 2-MiB-aligned mappings marked
// madvise(MADV_HUGEPAGE) on Linux (it is honoured when
// /sys/kernel/mm/transparent_hugepage/enabled is "madvise" or "always"); smaller ones, and all
// buffers elsewhere, come from operator new. Contents are not initialised, as with operator new.
// A huge buffer commits its memory in 2-MiB steps as it is written (up to 2 MiB more than a
// small-page one), so use it for buffers that are large and filled, not for many small ones.
#pragma once

#include <cstddef>
#include <new>

namespace ch {

/// Size (bytes) from which bigAllocate maps huge pages: one transparent huge page on x86-64.
inline constexpr std::size_t kHugePage = std::size_t{2} << 20;

/// `bytes` of uninitialised memory aligned to 64 bytes (2 MiB when bytes ≥ kHugePage, on Linux),
/// huge pages when the OS offers them. Throws std::bad_alloc. Free with bigFree(p, bytes).
void* bigAllocate(std::size_t bytes);
/// Frees what bigAllocate(bytes) returned (the same `bytes`); p may be null.
void bigFree(void* p, std::size_t bytes) noexcept;
/// Whether bigAllocate(bytes) maps huge pages for this size on this platform.
bool bigAllocateUsesHugePages(std::size_t bytes);

/// For a process about to make ~`bytes` of small allocations (parsing a large scenario: its
/// XML tree is ~7 times the file's size), on Linux with glibc: grows the malloc heap now by
/// `bytes` (rounded to 2 MiB, at most 512 MiB), marks that untouched part for huge pages, and
/// keeps it (M_TOP_PAD) and blocks up to half of it (M_MMAP_THRESHOLD) in the heap, so that
/// memory freed after loading is reused by the simulation rather than returned and faulted in
/// again. Once per process, and only from 4 MiB (a small scene keeps the default heap); false
/// when nothing was done. Process-wide: for a program that runs one scenario (the CLI's run);
/// the price is up to ~2 MiB more resident memory than with small pages.
bool heapOnHugePages(std::size_t bytes);

/// A standard allocator over bigAllocate, for containers that hold a large buffer for the whole
/// run (std::vector<T, BigAllocator<T>>). Stateless: all instances are equal.
template <class T>
struct BigAllocator {
    using value_type = T;
    BigAllocator() = default;
    template <class U>
    BigAllocator(const BigAllocator<U>&) noexcept {}
    T* allocate(std::size_t n) {
        if (n > static_cast<std::size_t>(-1) / sizeof(T)) throw std::bad_array_new_length();
        return static_cast<T*>(bigAllocate(n * sizeof(T)));
    }
    void deallocate(T* p, std::size_t n) noexcept { bigFree(p, n * sizeof(T)); }
    template <class U>
    bool operator==(const BigAllocator<U>&) const noexcept { return true; }
};

}  // namespace ch
