// core/big_alloc.h: buffers from bigAllocate are aligned, writable over their whole size and
// freed; BigAllocator keeps a vector's contents across growth past the huge-page size; the heap
// set up by heapOnHugePages still serves and frees blocks of every size.
#define BOOST_TEST_MODULE core_big_alloc
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/big_alloc.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

using namespace ch;

namespace {
std::uintptr_t address(const void* p) { return reinterpret_cast<std::uintptr_t>(p); }
}  // namespace

BOOST_AUTO_TEST_CASE(small_and_large_buffers_are_aligned_and_writable) {
    for (const std::size_t bytes : {std::size_t{1}, std::size_t{100}, std::size_t{4096}, kHugePage - 1, kHugePage,
                                    kHugePage + 1, 3 * kHugePage + 12345}) {
        unsigned char* p = static_cast<unsigned char*>(bigAllocate(bytes));
        BOOST_TEST_REQUIRE(p != nullptr);
        BOOST_TEST(address(p) % 64 == 0u, bytes << " bytes");
#if defined(__linux__)
        BOOST_TEST(bigAllocateUsesHugePages(bytes) == (bytes >= kHugePage));
        if (bytes >= kHugePage) BOOST_TEST(address(p) % kHugePage == 0u, bytes << " bytes");
#endif
        std::memset(p, 0xab, bytes);  // every byte is ours (ASan, or a fault past a short mapping)
        BOOST_TEST(p[0] == 0xab);
        BOOST_TEST(p[bytes - 1] == 0xab);
        bigFree(p, bytes);
    }
    bigFree(nullptr, kHugePage);  // like operator delete(nullptr): nothing
}

BOOST_AUTO_TEST_CASE(a_vector_keeps_its_contents_while_it_grows_past_huge_pages) {
    std::vector<std::uint64_t, BigAllocator<std::uint64_t>> v;
    const std::size_t n = 3 * kHugePage / sizeof(std::uint64_t) + 7;
    for (std::size_t i = 0; i < n; ++i) v.push_back(i * 2654435761u);
    bool same = true;
    for (std::size_t i = 0; i < n; ++i) same = same && v[i] == i * 2654435761u;
    BOOST_TEST(same);
    std::vector<std::uint64_t, BigAllocator<std::uint64_t>> copy = v;
    BOOST_TEST((copy == v));
    BOOST_TEST((BigAllocator<int>() == BigAllocator<double>()));
}

BOOST_AUTO_TEST_CASE(the_heap_on_huge_pages_serves_blocks_of_every_size) {
    BOOST_TEST(!heapOnHugePages(kHugePage));  // below 4 MiB: nothing done
    const bool done = heapOnHugePages(16 * kHugePage);
#if defined(__linux__) && defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
    BOOST_TEST(done);  // (AddressSanitizer's malloc never grows the brk heap: nothing to mark)
#endif
    (void)done;
    BOOST_TEST(!heapOnHugePages(16 * kHugePage));  // once per process
    std::vector<void*> blocks;
    std::size_t size = 8;
    for (int i = 0; i < 4000; ++i) {
        const std::size_t bytes = 1 + (size = size * 7 % 100003) * (i % 40 == 0 ? 97 : 1);
        void* p = std::malloc(bytes);
        BOOST_TEST_REQUIRE(p != nullptr);
        std::memset(p, i & 0xff, bytes);
        blocks.push_back(p);
        if (i % 3 == 0) {
            std::free(blocks[static_cast<std::size_t>(i) / 2]);
            blocks[static_cast<std::size_t>(i) / 2] = nullptr;
        }
    }
    for (void* p : blocks) std::free(p);
}
