// CrowdHealth — crowd-level safety measures on a grid, the heat map and the safety verdict
// (DESIGN §5–6, docs/crowd-health.md).
//
// Local density and crowd pressure after Helbing, Johansson & Al-Abideen 2007 ("Dynamics of crowd
// disasters: an empirical study", Phys. Rev. E 75, 046109): at a point r, with Gaussian weights
// f(d) = exp(−|d|²/R²)/(πR²),
//     ρ(r,t) = Σ_j f(x_j − r)                            (persons/m²)
//     V(r,t) = Σ_j f v_j / Σ_j f                         local velocity (m/s)
//     P(r)   = ρ(r) · ⟨|V(r,t) − U(r)|²⟩_t               crowd pressure (1/s²)
// where U(r) = ⟨V(r,t)⟩_t is the time-averaged local velocity and ⟨·⟩_t an average over a time
// window at the same place: the pressure is the local density times the variance *in time* of the
// local velocity, which is what grows in stop-and-go waves and crowd turbulence. Here ⟨·⟩_t is an
// exponential moving average with time constant SafetyThresholds::pressureWindow, updated every
// coarse step; ρ(r) is averaged the same way. Evaluated at the centres of square cells
// (SafetyThresholds::cellSize, 1 m by default). Agents only: walls and wall particles do not count.
#pragma once

#include "crowdhealth/core/big_alloc.h"
#include "crowdhealth/core/simulation.h"
#include "crowdhealth/io/json.h"

#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace ch {

/// The attributes of <Safety> (XML names, units, defaults = SafetyThresholds{}, ranges), for the
/// loader and the documentation check.
const ParamTable& safetyTable();

/// The crowd measures on the cells around the agents: every cell of the rectangle covering them
/// (one cell of margin), or, for a crowd scattered over a huge area, only the cells within reach
/// of an agent. Entries are sorted by (iy, ix).
struct CrowdField {
    double cellSize = 1;
    std::vector<int> ix, iy;       ///< cell (ix, iy) spans [ix·c, (ix+1)·c) × [iy·c, (iy+1)·c)
    std::vector<double> density;   ///< persons/m² at each cell centre
    /// Local velocity V(r,t) at each cell centre (m/s); unset where `weighted` is 0.
    std::vector<Vec2> velocity;
    /// 1 where some agent lies within reach of the centre (the local velocity is defined), else 0.
    std::vector<unsigned char> weighted;
    std::vector<int> people;       ///< agents whose centre lies in the cell
    /// The entry of each agent's cell (AgentStore index order): the cell its centre lies in.
    /// (32 bits: a field has at most a few million entries; 4 MB less at a million agents.)
    std::vector<std::uint32_t> cellOfAgent;
    std::size_t size() const { return ix.size(); }
    /// The entry of cell (x, y), or size() when it was not evaluated.
    std::size_t find(int x, int y) const;
    double maxDensity() const;
    Vec2 centre(int x, int y) const { return Vec2((x + 0.5) * cellSize, (y + 0.5) * cellSize); }
    static std::uint64_t cellKey(int x, int y);
    /// cellKey of each entry, ascending, for find() on cells scattered far apart; empty for the
    /// cells of a whole rectangle, which find() locates by their row and column.
    std::vector<std::uint64_t> keys_;
};

/// Fruin's (1971) level of service for walkways, from the area per person: A ≥ 35 ft² (3.25 m²),
/// B ≥ 25 ft², C ≥ 15 ft², D ≥ 10 ft², E ≥ 5 ft² (0.46 m²), F below. Density in persons/m²; an
/// empty area is A.
char fruinLevel(double density);
/// The lowest density (persons/m²) of each level B…F: 1/(35 ft²), 1/(25 ft²), … 1/(5 ft²).
double fruinLowerDensity(char level);

/// Evaluates the Helbing et al. 2007 local density and local velocity on the grid (one instant).
CrowdField crowdField(const AgentStore& agents, double cellSize = 1.0, double gaussianRadius = 0.7);

/// The builds of crowdField's scatter over a rectangle of cells and of SafetyRecorder's update of
/// its cells: 0 generic (two lanes, SSE2 registers on x86-64), 1 AVX2 (four lanes), 2 AVX-512
/// (eight lanes), all giving the same bits. The best this CPU runs is used; setCrowdFieldPath
/// returns false and changes nothing when this CPU cannot run `path` (tests compare the builds;
/// crowdhealth-bench --isa).
int crowdFieldPath();
bool setCrowdFieldPath(int path);

/// One reason of the verdict.
struct VerdictReason {
    std::string level;     ///< caution, dangerous or critical
    std::string measure;   ///< density, crowd_pressure, crush_force, crush_dose, injured, fallen, helping
    double threshold = 0;  ///< in `unit`
    std::string unit;
    double firstTime = std::numeric_limits<double>::quiet_NaN();  ///< s
    double duration = 0;   ///< s during which it held somewhere (injured: longest time above the crush threshold)
    std::size_t people = 0;
    bool hasWhere = false;
    double x = 0, y = 0, xmin = 0, xmax = 0, ymin = 0, ymax = 0;  ///< m: centroid and bounding box
    std::string place;     ///< the named exit, measurement line or area (empty: a region of cells)
    std::string text;      ///< one readable sentence
};

struct Verdict {
    std::string level = "safe";  ///< safe, caution, dangerous or critical
    std::vector<VerdictReason> reasons;  ///< most severe first
};

/// Rank of a level: safe 0, caution 1, dangerous 2, critical 3.
int verdictRank(const std::string& level);
/// Adds reasons (e.g. MeasurementRecorder::reasons()) to a verdict: most severe first (stable),
/// and the level is that of the most severe.
void addReasons(Verdict& v, std::vector<VerdictReason> more);

/// Follows the crowd measures over a run (call record() at t = 0 and after every coarse step)
/// and keeps, per cell, the peaks and the seconds each threshold held.
class SafetyRecorder {
public:
    explicit SafetyRecorder(SafetyThresholds t = {}) : t_(t) {}

    void record(const Simulation& sim);
    /// The crowd measures alone (density, crowd pressure; no contact or crush) from agents at
    /// time t (s), for states that do not come from a Simulation (tests, replayed trajectories).
    /// Times must rise; a second call at the same time is ignored, as in record().
    void recordCrowd(const AgentStore& agents, double t);
    const SafetyThresholds& thresholds() const { return t_; }
    /// The largest crowd pressure P(r) over the cells at the last record() (1/s², 0 before any):
    /// the `crowd_pressure` column of metrics.csv. Not gated by density (the verdict is).
    double maxPressure() const { return maxPressure_; }

    /// heatmap.csv: header `x,y,max_density,max_contact_accel,seconds_above_density_threshold,
    /// seconds_above_crush_threshold,worst_los`; one row per cell of the rectangle covering every
    /// cell ever evaluated, y ascending then x ascending; x, y = cell centre (m); the density
    /// threshold is densityDangerous, the crush threshold each agent's crushThreshold; worst_los =
    /// the worst of Fruin's walkway levels (A–F) the cell's local density held for minDuration
    /// without a break.
    std::string heatmapCsv() const;

    /// The verdict from these records and the simulation's health records.
    Verdict verdict(const Simulation& sim) const;

    enum Condition { DensityCaution, DensityDangerous, DensityCritical, Pressure, Crush, kConditions };

private:
    struct Cell {
        double maxDensity = 0, maxContact = 0;
        double seconds[kConditions] = {0, 0, 0, 0, 0};
        // Time averages at this place for the crowd pressure (exponential, SafetyThresholds::
        // pressureWindow): density, local velocity and its squared length. `sampledAt` is the
        // time of the last sample; a cell that missed a record (no agent within reach) restarts.
        double meanDensity = 0, meanSquaredSpeed = 0;
        Vec2 meanVelocity{0, 0};
        double sampledAt = std::numeric_limits<double>::quiet_NaN();
        /// Seconds each of Fruin's levels B…F (and worse) has held without a break, and the
        /// worst level that held for minDuration ('A' when none did).
        double losRun[5] = {0, 0, 0, 0, 0};
        double losAt = std::numeric_limits<double>::quiet_NaN();
        char worstLos = 'A';
    };
    struct Timeline {
        double firstTime = std::numeric_limits<double>::quiet_NaN();
        double seconds = 0;
        std::size_t maxPeople = 0;
    };
    SafetyThresholds t_;
    // The cells ever evaluated, in tiles of kTileSide × kTileSide cells made when one of their
    // cells is first evaluated. An index over the tiles' rectangle [tx0_, tx0_ + tnx_) ×
    // [ty0_, ty0_ + tny_) (tile units, row-major, y outer; -1 where no tile was made) grows
    // with some slack when the crowd moves out of it: only the index is copied, and a cell never
    // moves once made (a flat grid copied itself as it grew: a 471 m room's 36 MiB grid had its old
    // and new copies alive together, the 1M run's peak, issue 20). Each tile's `present` marks the
    // cells evaluated (the others keep a default Cell); bx0_…by1_ bound them. Beyond kMaxIndexTiles
    // or kMaxGridCells (a crowd scattered very far apart) the cells move to sparseCells_, keyed
    // (iy, ix), for the rest of the run. (A std::map for every run looked each cell up at every
    // coarse step: ~12 % of a 10k-agent social-forces run, issue 20.)
    // The tiles are made in blocks of one huge page (bigAllocate): a 10k-agent crowd's cells,
    // 3.7 MB, would otherwise cost ~900 page faults of 4 KiB each (issue 20).
    static constexpr int kTileBits = 4, kTileSide = 1 << kTileBits, kTileCells = kTileSide * kTileSide;
    /// The cells of a tile in blocks of kBlockCells consecutive cells of a row, field by field
    /// (lane l of each array: cell l of the block), so that a record updates a block's cells in
    /// vectors (issue 20: one cell at a time took ~45 % of the safety grid's time in a 10k-agent
    /// social-forces run). The same fields as Cell.
    static constexpr int kBlockBits = 3, kBlockCells = 1 << kBlockBits;
    struct alignas(64) CellBlock {
        double maxDensity[kBlockCells], maxContact[kBlockCells];
        double seconds[kConditions][kBlockCells];
        double meanDensity[kBlockCells], meanSquaredSpeed[kBlockCells];
        double meanVelocityX[kBlockCells], meanVelocityY[kBlockCells];
        double sampledAt[kBlockCells];
        double losRun[5][kBlockCells];
        double losAt[kBlockCells];
        char worstLos[kBlockCells];
        CellBlock();  ///< kBlockCells default cells
        Cell get(int lane) const;
        void set(int lane, const Cell& c);
    };
    struct Tile {
        CellBlock blocks[kTileCells / kBlockCells];
        unsigned char present[kTileCells] = {};
        Cell get(int c) const { return blocks[c >> kBlockBits].get(c & (kBlockCells - 1)); }
    };
    /// Tiles in blocks of kHugePage bytes, numbered in the order they were made; a tile stays
    /// where it was made until the store is cleared. Copies copy the tiles.
    class TileStore {
    public:
        TileStore() = default;
        TileStore(const TileStore& o);
        TileStore& operator=(const TileStore& o) {
            if (this != &o) *this = TileStore(o);
            return *this;
        }
        TileStore(TileStore&& o) noexcept { swap(o); }
        TileStore& operator=(TileStore&& o) noexcept {
            TileStore gone(std::move(o));
            swap(gone);
            return *this;
        }
        ~TileStore() { clear(); }
        /// A new tile of default cells, none present; returns its number.
        int make();
        Tile& operator[](int k) {
            const std::size_t u = static_cast<std::size_t>(k);
            return static_cast<Tile*>(blocks_[u / kPerBlock])[u % kPerBlock];
        }
        const Tile& operator[](int k) const { return const_cast<TileStore&>(*this)[k]; }
        std::size_t size() const { return count_; }
        void clear() noexcept;

    private:
        static constexpr std::size_t kPerBlock = kHugePage / sizeof(Tile);
        std::vector<void*> blocks_;
        std::size_t count_ = 0;
        void swap(TileStore& o) noexcept {
            blocks_.swap(o.blocks_);
            std::swap(count_, o.count_);
        }
    };
    static constexpr double kMaxGridCells = 1 << 22;  ///< most cells in tiles (608 MB) before the map
    static constexpr double kMaxIndexTiles = 1 << 20;  ///< largest index (4 MB of tile numbers, ~16 km a side)
    static constexpr int kIndexSlack = 4;             ///< tiles an index side grows by beyond the need
    TileStore store_;
    std::vector<int> tiles_;  ///< the number of each tile in store_, -1 where none was made
    int tx0_ = 0, ty0_ = 0, tnx_ = 0, tny_ = 0;
    int bx0_ = 0, bx1_ = -1, by0_ = 0, by1_ = -1;  ///< bounds of the present cells (empty: bx1_ < bx0_)
    bool sparse_ = false;
    std::map<std::pair<int, int>, Cell> sparseCells_;
    Timeline timeline_[kConditions];
    double lastTime_ = std::numeric_limits<double>::quiet_NaN();
    double maxPressure_ = 0;

    void recordAt(const AgentStore& agents, double t, const HealthLayer* health);
    /// Makes the tile index cover cells [x0, x1] × [y0, y1] (tiles are made by makeTile); false when
    /// that would exceed kMaxIndexTiles (the cells have then moved to sparseCells_).
    bool cover(int x0, int y0, int x1, int y1);
    /// The index slot of the tile holding cell (x, y), which the index covers.
    int& tileSlot(int x, int y) {
        return tiles_[static_cast<std::size_t>((y >> kTileBits) - ty0_) * static_cast<std::size_t>(tnx_) +
                      static_cast<std::size_t>((x >> kTileBits) - tx0_)];
    }
    /// The tile holding cell (x, y); null when none was made (or the cells are in the map).
    const Tile* tileOf(int x, int y) const {
        if (sparse_ || tnx_ == 0) return nullptr;
        const int tx = (x >> kTileBits) - tx0_, ty = (y >> kTileBits) - ty0_;
        if (tx < 0 || ty < 0 || tx >= tnx_ || ty >= tny_) return nullptr;
        const int k = tiles_[static_cast<std::size_t>(ty) * static_cast<std::size_t>(tnx_) + static_cast<std::size_t>(tx)];
        return k >= 0 ? &store_[k] : nullptr;
    }
    static int inTile(int x, int y) { return ((y & (kTileSide - 1)) << kTileBits) | (x & (kTileSide - 1)); }
    /// Makes the tile of slot `slot` if it is missing; false (and the cells move to the map) when
    /// one more tile would exceed kMaxGridCells.
    bool makeTile(int& slot);
    /// Moves the evaluated cells to sparseCells_, for good.
    void goSparse();
    /// f(x, y, cell) for every evaluated cell, y ascending then x ascending.
    template <class F>
    void forEachCell(F&& f) const;
    VerdictReason cellReason(Condition c, const std::string& level, const std::string& measure, double threshold,
                             const std::string& unit, const std::string& what) const;
};

/// The verdict as a JSON object {"level": …, "reasons": […]} (summary.json's "verdict").
Json verdictJsonValue(const Verdict& v);
/// verdictJsonValue serialised on one line by the JSON library.
std::string verdictJson(const Verdict& v);
/// Human-readable lines: "safety verdict: DANGEROUS" then one line per reason.
std::string verdictText(const Verdict& v);

}  // namespace ch
