// CrowdHealth — per-step neighbour lists: every agent's neighbouring agents and wall segments,
// found once per step and shared by all components (SPH density, contact, the per-agent calls).
#pragma once

#include "crowdhealth/core/big_alloc.h"
#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/types.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <type_traits>
#include <vector>

namespace ch {

class World;

/// A neighbouring agent of the query agent, as the per-agent calls read it (AgentQuery::agents): 24
/// bytes, the distance not stored (distance() recomputes exactly the value |offset| the grid saw).
/// Stored lists keep only the index (NeighbourLists::indices); these entries live in per-thread
/// scratch written from them (NeighbourLists::agents) or by the streamed gather.
struct NeighbourAgent {
    /// pos[j] - pos[i], shortest on a torus (m). Stored without Vec2's 16-byte alignment (which
    /// would pad the entry to 32 bytes); it converts to Vec2 wherever one is expected.
    Eigen::Matrix<double, 2, 1, Eigen::DontAlign> offset;
    int index;    ///< index j in AgentStore

    double distanceSquared() const { return offset.squaredNorm(); }
    double distance() const { return offset.norm(); }  ///< |offset| (m); costs a square root
};
static_assert(sizeof(NeighbourAgent) == 24, "NeighbourAgent should stay 24 bytes (the AVX-512 loaders read three 8-byte words)");

/// The neighbourhoods of one step. Agent i's list holds every other agent within radius(i) (in
/// the grid's visit order, so sums over it do not depend on the thread count) and every wall
/// segment within radius(i) (ascending index). Built in parallel into per-thread buffers that are
/// kept from step to step, so a step allocates nothing once the buffers have grown.
/// Memory (issue 20): a list stores only its agents' indices, 4 bytes per neighbour pair within
/// range (about 14 per agent in a dense SPH crowd); the offsets are computed where a list is read,
/// from the positions the lists were built over (agents(), forEachAgent()), to the bit those the
/// grid saw. So those positions must stay in place and unchanged until the lists are next built.
class NeighbourLists {
public:
    /// Rebuilds the lists for `positions` from `grid` (built over the same positions, cells of any
    /// size: the simulation's are half the largest radius below kFineGridFrom). Agent i's radius
    /// is rangeOfGroup[group[i]]. When the largest radius is at least kFineGridFrom (and the world
    /// is not periodic) the lists are gathered from a grid of cells a kFineGridCells-th of it
    /// instead, built here: fewer candidates to test, the lists then in that grid's visit order.
    void build(const std::vector<Vec2>& positions, const PointGrid& grid, const World& world,
               const std::vector<int>& group, const std::vector<double>& rangeOfGroup);

    /// How the lists are gathered (issue 20), chosen when the program starts: 0 generic (a scalar
    /// branch-free append per candidate), 1 AVX2, 2 AVX-512 (x86-64 CPUs that have them; periodic
    /// worlds always use 0). All give the same lists, entry by entry, to the bit.
    static int gatherPath();
    /// Forces gather path `path` (tests, benchmarks); false (and no change) if this CPU lacks it.
    static bool setGatherPath(int path);

    /// Largest list radius (m) from which lists are gathered from a finer grid of their own.
    static constexpr double kFineGridFrom = 2.0;
    /// Cells per list radius in that grid.
    static constexpr double kFineGridCells = 4.0;

    /// Streaming instead of storing (issue 20): sets up for gather() over `positions` (which must
    /// stay in place until the lists are next built or bound) without building any list, for a
    /// step whose lists are each read only while their own agent is evaluated. Every list a
    /// gather() returns is the one build() would store, entry by entry and in the same order. Until
    /// the next build(), size() is 0, so StepContext's helpers query the grid instead.
    void bind(const std::vector<Vec2>& positions, const PointGrid& grid, const World& world,
              const std::vector<int>& group, const std::vector<double>& rangeOfGroup);
    /// Whether the lists are bound for gather() (the last call was bind()) rather than stored.
    bool streaming() const { return streaming_; }
    /// A thread's buffers for gather() (and for agents() in Simulation::gatherQuery): one agent's
    /// lists, reused from agent to agent (a few kilobytes that stay in cache, where the stored
    /// lists of 10k agents at 5 m are ~3 MB of indices).
    struct Scratch {
        std::vector<NeighbourAgent> agents;
        std::vector<int> segments;
    };
    /// After bind(): agent i's lists into `scratch`, as spans valid until its next gather().
    void gather(std::size_t i, Scratch& scratch, std::span<const NeighbourAgent>& agents,
                std::span<const int>& segments) const;

    /// Agents with stored lists: those of the last build(); 0 after bind().
    std::size_t size() const { return slices_.size(); }
    /// The radius (m) agent i's lists were gathered with.
    double radius(std::size_t i) const { return rangeOfGroup_[static_cast<std::size_t>((*group_)[i])]; }
    /// Other agents within radius(i): their indices in AgentStore, as stored.
    std::span<const int> indices(std::size_t i) const {
        const Slice& s = slices_[i];
        return {buffers_[s.thread].data(s.block, s.begin), s.count};
    }
    /// positions[j] − positions[i] (the shortest such vector on a torus): the offset the grid saw
    /// when it put j in i's list, to the bit.
    Vec2 offset(std::size_t i, int j) const {
        const std::vector<Vec2>& p = *positions_;
        return periodic_ ? gridUsed_->offset(p[i], p[static_cast<std::size_t>(j)]) : Vec2(p[static_cast<std::size_t>(j)] - p[i]);
    }
    /// The positions the lists were built over (offset() reads them).
    const std::vector<Vec2>& positions() const { return *positions_; }
    /// Whether every offset is the plain difference positions[j] − positions[i] (not a torus):
    /// readers may then compute the offsets themselves from indices() (Policies/PairSums.h).
    bool plane() const { return !periodic_; }
    /// Agent i's list with its offsets, written into `scratch` (kept by the caller: it grows to the
    /// longest list and then allocates nothing); valid until `scratch` changes.
    std::span<const NeighbourAgent> agents(std::size_t i, std::vector<NeighbourAgent>& scratch) const;
    /// f(j, offset) for every agent of i's list, in its order, without a scratch.
    template <class F>
    void forEachAgent(std::size_t i, F&& f) const {
        const std::span<const int> list = indices(i);
        for (const int j : list) f(j, offset(i, j));
    }
    /// How many walls segments(i) holds.
    std::size_t segmentCount(std::size_t i) const { return slices_[i].segments; }
    /// Wall segments within radius(i), ascending.
    std::span<const int> segments(std::size_t i) const {
        const Slice& s = slices_[i];
        return {buffers_[s.thread].data(s.block, s.begin) + s.count, s.segments};
    }

private:
    /// Where a list starts: block and offset in a BlockBuffer.
    struct Place {
        std::size_t block = 0, begin = 0;
    };

    /// Append-only storage made of blocks that never reallocate. A list is written in place after
    /// asking for room for its largest possible size (the grid's candidate count); if the current
    /// block lacks that room the list starts in the next block. So every list is contiguous,
    /// views stay valid, nothing is copied, and memory is the lists' size plus a little slack.
    /// The first block holds kBlock entries (a small scene commits only the pages it writes);
    /// later ones are whole multiples of 2 MiB, doubling up to kMaxBlockBytes, from bigAllocate:
    /// huge pages where the OS offers them (one page fault per 2 MiB instead of 512, issue 20).
    template <class T>
    class BlockBuffer {
    public:
        /// Forgets the contents, keeps the blocks.
        void clear() {
            for (Block& b : blocks_) b.used = 0;
            current_ = 0;
        }
        /// Room for up to `most` entries of a new list: sets `at` and returns where to write.
        T* open(Place& at, std::size_t most) {
            if (blocks_.empty()) blocks_.emplace_back();
            if (blocks_[current_].used + most > blocks_[current_].capacity && blocks_[current_].used > 0) {
                ++current_;
                if (blocks_.size() <= current_) blocks_.emplace_back();
            }
            Block& b = blocks_[current_];
            if (b.capacity < b.used + most) {  // a fresh or too small (empty) block
                b.data.reset();
                b.capacity = capacityOf(current_, most);
                T* p = static_cast<T*>(bigAllocate(b.capacity * sizeof(T)));
                std::uninitialized_default_construct_n(p, b.capacity);  // no code: nothing is written
                b.data = Data(p, BigDelete{b.capacity * sizeof(T)});
            }
            at = Place{current_, b.used};
            return b.data.get() + b.used;
        }
        /// The list opened at `at` holds `count` entries.
        void close(const Place& at, std::size_t count) { blocks_[at.block].used = at.begin + count; }
        const T* data(std::uint32_t block, std::uint32_t begin) const { return blocks_[block].data.get() + begin; }

    private:
        static_assert(std::is_trivially_destructible_v<T>);  // blocks are freed without destructors
        static constexpr std::size_t kBlock = std::size_t{1} << 16;  ///< entries of the first block
        static constexpr std::size_t kMaxBlockBytes = std::size_t{64} << 20;  ///< largest doubling
        /// Entries of block `index` when it must hold a list of `most`.
        static std::size_t capacityOf(std::size_t index, std::size_t most) {
            if (index == 0 && most <= kBlock) return kBlock;
            const std::size_t doubling = kHugePage << std::min<std::size_t>(index, 5);
            std::size_t bytes = std::max(std::min(doubling, kMaxBlockBytes), most * sizeof(T));
            bytes = (bytes + kHugePage - 1) / kHugePage * kHugePage;
            return bytes / sizeof(T);
        }
        struct BigDelete {
            std::size_t bytes = 0;
            void operator()(T* p) const noexcept { bigFree(p, bytes); }
        };
        using Data = std::unique_ptr<T, BigDelete>;
        struct Block {
            Data data;
            std::size_t capacity = 0, used = 0;
        };
        std::vector<Block> blocks_;
        std::size_t current_ = 0;
    };

    /// One agent's lists, 16 bytes: `count` agent indices from `begin` in block `block` of thread
    /// `thread`'s buffer, then its `segments` wall segments (one slice for both lists: 16 MB less
    /// at a million agents than a slice for each, issue 20).
    struct Slice {
        std::uint32_t begin, count, segments;
        std::uint16_t thread, block;
    };
    static_assert(sizeof(Slice) == 16);
    static Slice slice(int thread, const Place& at, std::size_t count, std::size_t segments);
    /// The grid the lists come from (fine_ for long ranges, else `stepGrid`), after building fine_
    /// when needed; also keeps group and rangeOfGroup.
    const PointGrid& prepareGrid(const std::vector<Vec2>& positions, const PointGrid& stepGrid, const World& world,
                                 const std::vector<int>& group, const std::vector<double>& rangeOfGroup);
    /// Agent i's agent list, written where open(most) says (room for `most` entries: indices for
    /// build(), whole entries for gather()); returns its length. The one gather of both.
    template <class Open>
    std::size_t gatherAgents(const PointGrid& grid, const Vec2& p, double r, int self, Open&& open) const;

    std::vector<BlockBuffer<int>> buffers_;   ///< one per thread: each agent's indices, then its segments
    std::vector<std::vector<int>> scratch_;   ///< one per thread: segment query
    std::vector<Slice> slices_;               ///< per agent, into the buffers
    PointGrid fine_;  ///< the finer grid for long ranges (kept: no allocation per step)
    const std::vector<int>* group_ = nullptr;
    std::vector<double> rangeOfGroup_;
    // build() and bind(): what offset() and gather() read.
    bool streaming_ = false;
    bool periodic_ = false;
    const std::vector<Vec2>* positions_ = nullptr;
    const PointGrid* gridUsed_ = nullptr;
    const World* world_ = nullptr;
};

}  // namespace ch
