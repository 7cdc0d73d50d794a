// CrowdHealth — crowd-level safety measures on a grid, the heat map and the safety verdict
// (DESIGN §5–6, docs/crowd-health.md).
//
// Local density and crowd pressure after Helbing, Johansson & Al-Abideen 2007 (Phys. Rev. E 75,
// 046109): at a point r, with Gaussian weights f(d) = exp(−|d|²/R²)/(πR²),
//     ρ(r) = Σ_j f(x_j − r)                              (persons/m²)
//     U(r) = Σ_j f v_j / Σ_j f,  Var(r) = Σ_j f |v_j − U(r)|² / Σ_j f
//     P(r) = ρ(r) · Var(r)                               (1/s²)
// evaluated at the centres of square cells (SafetyThresholds::cellSize, 1 m by default) with
// instantaneous velocities. Agents only: walls and wall particles do not count.
#pragma once

#include "crowdhealth/simulation.h"

#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace ch {

/// The attributes of <Safety> (XML names, units, defaults = SafetyThresholds{}, ranges), for the
/// loader and the documentation check.
const ParamTable& safetyTable();

/// The crowd measures on the cells covering the agents (one cell of margin).
struct CrowdField {
    double cellSize = 1;
    int ix0 = 0, iy0 = 0, nx = 0, ny = 0;  ///< cell (ix, iy) spans [ix·c, (ix+1)·c) × [iy·c, (iy+1)·c)
    std::vector<double> density;   ///< persons/m² at each cell centre, row-major (y outer)
    std::vector<double> pressure;  ///< 1/s²
    std::vector<int> people;       ///< agents whose centre lies in the cell
    double maxDensity() const;
    double maxPressure() const;
    Vec2 centre(int ix, int iy) const { return Vec2((ix + 0.5) * cellSize, (iy + 0.5) * cellSize); }
};

/// Evaluates the Helbing et al. 2007 local density and crowd pressure on the grid.
CrowdField crowdField(const AgentStore& agents, double cellSize = 1.0, double gaussianRadius = 0.7);

/// One reason of the verdict.
struct VerdictReason {
    std::string level;     ///< caution, dangerous or critical
    std::string measure;   ///< density, crowd_pressure, crush_force, crush_dose, injured
    double threshold = 0;  ///< in `unit`
    std::string unit;
    double firstTime = std::numeric_limits<double>::quiet_NaN();  ///< s
    double duration = 0;   ///< s during which it held somewhere (injured: longest time above the crush threshold)
    std::size_t people = 0;
    bool hasWhere = false;
    double x = 0, y = 0, xmin = 0, xmax = 0, ymin = 0, ymax = 0;  ///< m: centroid and bounding box
    std::string text;      ///< one readable sentence
};

struct Verdict {
    std::string level = "safe";  ///< safe, caution, dangerous or critical
    std::vector<VerdictReason> reasons;  ///< most severe first
};

/// Rank of a level: safe 0, caution 1, dangerous 2, critical 3.
int verdictRank(const std::string& level);

/// Follows the crowd measures over a run (call record() at t = 0 and after every coarse step)
/// and keeps, per cell, the peaks and the seconds each threshold held.
class SafetyRecorder {
public:
    explicit SafetyRecorder(SafetyThresholds t = {}) : t_(t) {}

    void record(const Simulation& sim);
    const SafetyThresholds& thresholds() const { return t_; }

    /// heatmap.csv: header `x,y,max_density,max_contact_accel,seconds_above_density_threshold,
    /// seconds_above_crush_threshold`; one row per cell of the rectangle covering every cell ever
    /// evaluated, y ascending then x ascending; x, y = cell centre (m); the density threshold is
    /// densityDangerous, the crush threshold each agent's crushThreshold.
    std::string heatmapCsv() const;

    /// The verdict from these records and the simulation's health records.
    Verdict verdict(const Simulation& sim) const;

    enum Condition { DensityCaution, DensityDangerous, DensityCritical, Pressure, Crush, kConditions };

private:
    struct Cell {
        double maxDensity = 0, maxContact = 0;
        double seconds[kConditions] = {0, 0, 0, 0, 0};
    };
    struct Timeline {
        double firstTime = std::numeric_limits<double>::quiet_NaN();
        double seconds = 0;
        std::size_t maxPeople = 0;
    };
    SafetyThresholds t_;
    std::map<std::pair<int, int>, Cell> cells_;  ///< key (iy, ix): y outer, x inner
    Timeline timeline_[kConditions];
    double lastTime_ = std::numeric_limits<double>::quiet_NaN();

    VerdictReason cellReason(Condition c, const std::string& level, const std::string& measure, double threshold,
                             const std::string& unit, const std::string& what) const;
};

/// The verdict as a JSON object (no trailing newline), `indent` spaces before nested lines.
std::string verdictJson(const Verdict& v, int indent = 2);
/// Human-readable lines: "safety verdict: DANGEROUS" then one line per reason.
std::string verdictText(const Verdict& v);

}  // namespace ch
