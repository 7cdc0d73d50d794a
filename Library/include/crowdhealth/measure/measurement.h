// CrowdHealth — measurement lines and areas (DESIGN §8, docs/measurement.md): what a safety
// engineer counts at doors and watches in zones. Plain specs filled by the XML loader (or by hand,
// or from DXF layers); the recorders that fill flows.csv and areas.csv follow them.
#pragma once

#include "crowdhealth/core/types.h"
#include "crowdhealth/io/diagnostics.h"

#include <string>
#include <vector>

namespace ch {

/// <Line id x1 y1 x2 y2/> in <Measurement>: counts the agents crossing the segment from a to
/// b, per direction. "Forward" is across the line towards its right-hand side seen from a looking
/// at b (the normal (b − a) rotated by −90°); "backward" the other way.
struct MeasureLineSpec {
    std::string name;
    Vec2 a{0, 0}, b{0, 0};  ///< m
    SourceLoc loc;
    double length() const { return (b - a).norm(); }
};

/// <Area id xmin xmax ymin ymax/> or <Area id><Point x y/>…</Area> in <Measurement>: a zone whose
/// density, speed, specific flow and level of service are recorded over time.
struct MeasureAreaSpec {
    std::string name;
    std::vector<Vec2> polygon;  ///< m, vertices in order (a rectangle: four)
    SourceLoc loc;
};

/// <Measurement interval> in <Simulation>: every line and area, and the interval of the rows.
struct MeasurementSpec {
    double interval = 1.0;  ///< s between rows of flows.csv and areas.csv
    std::vector<MeasureLineSpec> lines;
    std::vector<MeasureAreaSpec> areas;
    SourceLoc loc;
    bool empty() const { return lines.empty() && areas.empty(); }
};

}  // namespace ch
