// crowdhealth plot — the data of los.png, flows.png and areas.png (docs/measurement.md, "Plots"):
// heatmap.csv's worst_los column as a grid of Fruin levels, Fruin's colours and ranges, and
// flows.csv and areas.csv per line, exit and area. Nothing here draws; plot_measure.cpp does.
#pragma once

#include "plot_data.h"

#include <crowdhealth/core/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace chplot {

/// The unit vector from a measurement line a → b towards its forward side (the right-hand side
/// seen from a looking at b: (b − a) turned by −90°), where the maps draw its arrow; (0, 0) when
/// a = b.
ch::Vec2 forwardDirection(const ch::Vec2& a, const ch::Vec2& b);

/// One cell of the level-of-service map.
struct LosCell {
    double x = 0, y = 0;  ///< cell centre (m)
    char level = 'A';     ///< worst of Fruin's levels held for min_duration, 'A'…'F'
    bool reached = false; ///< someone came within reach of the cell (max_density > 0)
};

/// Reads heatmap.csv's x, y, max_density and worst_los columns. `hasLos` is false (and `cells`
/// empty) for a heatmap.csv without a worst_los column (runs older than the measurement). Returns
/// an error message naming the file and line (a level other than A–F, a bad number), or "".
std::string readLosGrid(const std::filesystem::path& heatmapCsv, std::vector<LosCell>& cells, bool& hasLos);

/// The cells of several runs on one grid (cells matched to the millimetre): the worst level of
/// any run, reached when any run reached it. Sorted by (y, x).
std::vector<LosCell> combineLos(const std::vector<std::vector<LosCell>>& runs);

/// Fruin's conventional colour of a level as 0xRRGGBB: A blue, B light blue, C green, D yellow,
/// E orange, F red (as pedestrian-simulation LoS maps draw them). Anything else: white.
unsigned losColour(char level);
/// The same as "#rrggbb".
std::string losColourHex(char level);
/// The legend text of a level with its range as ch::fruinLevel draws the boundaries, e.g.
/// "C: 0.43 < ρ ≤ 0.72 P/m² (1.39 to 2.32 m²/P)"; A "ρ ≤ 0.31 …", F "ρ > 2.15 …".
std::string losLegend(char level);

/// One measurement line or exit of flows.csv.
struct FlowSeries {
    std::string name;
    bool exit = false;     ///< kind "exit"
    double width = 0;      ///< m: flow / specific_flow on a row with a flow (0 when it never had one)
    Curve specificFlow;    ///< (time, specific_flow) per interval, P/(m·s)
    Curve forward, backward;  ///< (time, crossings in the interval)
    int totalForward = 0, totalBackward = 0;
};

/// Reads flows.csv (`time,line,kind,forward,backward,flow,specific_flow`): one series per line or
/// exit (a line and an exit of the same name are two series), in the order they first appear. Returns an error naming the file and line, or "".
std::string readFlows(const std::filesystem::path& csv, std::vector<FlowSeries>& series);

/// The specific flow over the last `window` seconds at each row of `s` (crossings in (t − window,
/// t] / window / width), as the verdict's flow_capacity reason measures it, from the per-interval
/// counts. Empty when the series has no width (never a crossing).
Curve windowedSpecificFlow(const FlowSeries& s, double window);

/// One measurement area of areas.csv.
struct AreaSeries {
    std::string name;
    Curve density, speed, specificFlow, people;  ///< (time, value)
    std::vector<char> los;                       ///< per row
};

/// Reads areas.csv (`time,area,density,speed,specific_flow,los,people`): one series per area, in
/// the order they first appear. Returns an error naming the file and line, or "".
std::string readAreas(const std::filesystem::path& csv, std::vector<AreaSeries>& series);

}  // namespace chplot
