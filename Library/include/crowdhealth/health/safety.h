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
    std::vector<std::size_t> cellOfAgent;
    std::size_t size() const { return ix.size(); }
    /// The entry of cell (x, y), or size() when it was not evaluated.
    std::size_t find(int x, int y) const;
    double maxDensity() const;
    Vec2 centre(int x, int y) const { return Vec2((x + 0.5) * cellSize, (y + 0.5) * cellSize); }
    static std::uint64_t cellKey(int x, int y);
    std::vector<std::uint64_t> keys_;  ///< cellKey of each entry, ascending (for find())
};

/// Fruin's (1971) level of service for walkways, from the area per person: A ≥ 35 ft² (3.25 m²),
/// B ≥ 25 ft², C ≥ 15 ft², D ≥ 10 ft², E ≥ 5 ft² (0.46 m²), F below. Density in persons/m²; an
/// empty area is A.
char fruinLevel(double density);
/// The lowest density (persons/m²) of each level B…F: 1/(35 ft²), 1/(25 ft²), … 1/(5 ft²).
double fruinLowerDensity(char level);

/// Evaluates the Helbing et al. 2007 local density and local velocity on the grid (one instant).
CrowdField crowdField(const AgentStore& agents, double cellSize = 1.0, double gaussianRadius = 0.7);

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
    // The cells ever evaluated. While the rectangle around them is at most kMaxGridCells, a flat
    // grid over [gx0_, gx0_ + gnx_) × [gy0_, gy0_ + gny_), row-major (y outer), that grows with some
    // slack when the crowd moves out of it; present_ marks the cells evaluated (the others keep a
    // default Cell), bx0_…by1_ bound them. Beyond that (a crowd scattered far apart) the cells move
    // to sparse_, keyed (iy, ix), for the rest of the run. (A std::map for every run looked each
    // cell up at every coarse step: ~12 % of a 10k-agent social-forces run, issue 20.)
    // The grid comes from bigAllocate (huge pages from 2 MiB): a 10k-agent crowd's grid grows
    // twice in its first seconds, to 3.7 MB, ~1900 page faults of 4 KiB each (issue 20).
    static constexpr double kMaxGridCells = 1 << 22;
    static constexpr int kMaxGrowCells = 32;  ///< most cells a side of the flat grid grows by beyond the need
    using Grid = std::vector<Cell, BigAllocator<Cell>>;
    Grid grid_;
    std::vector<unsigned char> present_;
    int gx0_ = 0, gy0_ = 0, gnx_ = 0, gny_ = 0;
    int bx0_ = 0, bx1_ = -1, by0_ = 0, by1_ = -1;  ///< bounds of the present cells (empty: bx1_ < bx0_)
    bool sparse_ = false;
    std::map<std::pair<int, int>, Cell> sparseCells_;
    Timeline timeline_[kConditions];
    double lastTime_ = std::numeric_limits<double>::quiet_NaN();
    double maxPressure_ = 0;

    void recordAt(const AgentStore& agents, double t, const HealthLayer* health);
    /// Makes the flat grid cover cells [x0, x1] × [y0, y1]; false when that would exceed
    /// kMaxGridCells (the cells have then moved to sparse_).
    bool cover(int x0, int y0, int x1, int y1);
    /// The cell (x, y), evaluated from now on.
    Cell& cellAt(int x, int y);
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
