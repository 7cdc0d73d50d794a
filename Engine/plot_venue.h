// crowdhealth plot — the venue drawn over a map (paths.png, heatmap.png, los.png): walls (filled
// when closed), targets and exits outlined and named, measurement lines (named, with an arrow to
// their forward side) and measurement areas (outlined, named), from the run's scenario.
#pragma once

#include "plot_data.h"
#include "plot_gnuplot.h"
#include "render_scene.h"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace chplot {

/// An axis-aligned extent that grows (m).
struct Extent {
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    void grow(double x, double y);
    bool empty() const { return x0 > x1; }
    /// A margin of `fraction` of the larger side (at least 1 m of side); a unit box when empty.
    void pad(double fraction);
};

/// How the venue is drawn.
struct VenueStyle {
    /// Exits in their own colours (paths.png: seriesColour in the scenario's order); else every
    /// exit in one dark colour (the maps, whose cells are coloured already).
    bool exitColours = true;
    /// Closed obstacles filled in front of the data (maps) rather than behind it (paths.png).
    bool fillInFront = false;
};

/// The venue of a run, ready to draw.
class VenueOverlay {
public:
    /// From the run's scenario (chrender::loadRunScenario). On failure has() is false and `note`
    /// says why (the map is then drawn without the venue).
    static VenueOverlay load(const RunData& run, std::string& note);
    explicit VenueOverlay(std::optional<ch::ScenarioSpec> spec = std::nullopt);

    bool has() const { return spec_.has_value(); }
    const std::optional<ch::ScenarioSpec>& spec() const { return spec_; }
    const std::vector<chrender::VenueMark>& marks() const { return marks_; }
    /// The scenario's exits, then `more` names not among them (paths.png adds exits that appear
    /// only in evacuations.csv): the colour order.
    void addExitName(const std::string& name);
    /// An exit's colour in paths.png (its place among the exit names), grey for "".
    std::string exitColour(const std::string& exit) const;

    /// Grows `e` by the walls, targets, exits and measurement lines and areas.
    void grow(Extent& e) const;
    /// Sets gnuplot objects, labels and arrows (tags from `tag` on, returned past the last used):
    /// filled closed walls, target and exit names, point targets' circles, measurement lines'
    /// names and forward arrows (length `arrow` m), measurement areas' names. They stay for every
    /// panel of a multiplot.
    int setObjects(GnuplotJob& job, int tag, const VenueStyle& style, double arrow) const;
    /// Appends the plot elements (with their data blocks) of the walls, the targets' and exits'
    /// outlines and the measurement lines and areas, with key entries.
    void addElements(std::vector<std::string>& elements, std::vector<Rows>& blocks, const VenueStyle& style) const;

private:
    std::optional<ch::ScenarioSpec> spec_;
    std::vector<chrender::VenueMark> marks_;
    std::vector<std::string> exitNames_;
};

/// Colours of the venue drawing.
inline constexpr const char* kNoExitColour = "#a0a0a0";
inline constexpr const char* kWallColour = "#303030";
inline constexpr const char* kTargetColour = "#000000";
inline constexpr const char* kMeasureColour = "#c0008c";  ///< measurement lines and areas (magenta)

}  // namespace chplot
