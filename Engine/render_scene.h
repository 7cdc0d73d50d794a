// crowdhealth — what the renderer (`crowdhealth render`) and the viewer (`crowdhealth-viewer`)
// share: loading a scenario for display, the colourings and their colour maps, the extent of a
// scene, and the per-agent values of a running simulation.
#pragma once

#include <crowdhealth/core/scenario.h>
#include <crowdhealth/core/simulation.h>

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace chrender {

struct Rgb {
    double r = 0, g = 0, b = 0;  ///< 0..1
};

/// The CrowdHealth paper's density colour map: d = min(5π/4, 5πρ/32),
/// (r, g, b) = (max(0, −cos d), max(0, sin d), ρ < 4 ? cos d : −sin d) — blue at 0, green ≈ 3.2,
/// red ≈ 6.4, pink from 8 on. ρ in 1/m².
Rgb densityColour(double rho);
/// The map for values in [0, 1] of the other colourings (contact, panic, injury): black → blue →
/// red → yellow (gnuplot's default "traditional pm3d" palette, rgbformulae 7,5,15).
Rgb heatColour(double fraction);

enum class Colouring { Density, Contact, Panic, Injury, None };
/// "density", "contact", "panic", "injury", "none"; nullopt for anything else.
std::optional<Colouring> parseColouring(const std::string& name);
std::string colouringName(Colouring c);
/// Colour-bar label, e.g. "SPH density (1/m²)".
std::string colouringLabel(Colouring c);

/// Loads a scenario; prints every diagnostic to `err` and returns nullopt on error.
std::optional<ch::ScenarioSpec> loadForDisplay(const std::string& path, std::ostream& err);

/// The scenario of a finished run (`render --replay`, `plot`'s paths.png): the file named by
/// DIR/summary.json's "scenario" (as given, else relative to DIR or DIR's parent), loaded with
/// the run's seed so that generated agents get the radii they had. Prints the loader's
/// diagnostics to `diagnostics`; on failure returns nullopt with `error` set (one sentence, no
/// program-name prefix).
std::optional<ch::ScenarioSpec> loadRunScenario(const std::filesystem::path& dir, std::string& error,
                                                std::ostream& diagnostics);

/// The targets and exits of a scenario's venue as drawn: outline (closed polygon; a point target
/// as a circle), name, exit or not, and the times the exit closes and reopens.
struct VenueMark {
    std::string name;
    bool exit = false;
    bool point = false;               ///< a point target: a circle of `radius` round `centre`
    std::vector<ch::Vec2> outline;    ///< polygon vertices (not repeated at the end)
    ch::Vec2 centre{0, 0};
    double radius = 0;
    std::vector<std::pair<double, bool>> events;  ///< (time s, open) in time order
    /// Whether the exit is open at time t (s): the state set by the last event at or before t.
    bool openAt(double t) const;
};
std::vector<VenueMark> venueMarks(const ch::ScenarioSpec& spec);

/// An axis-aligned rectangle of the world (m).
struct Box {
    double xmin = 0, xmax = 0, ymin = 0, ymax = 0;
    double width() const { return xmax - xmin; }
    double height() const { return ymax - ymin; }
};
/// What a scene covers: every obstacle vertex, every agent's start and goal, every target and
/// exit of a venue (and a planar world's bounds), plus a margin of 1 m.
Box sceneBounds(const ch::ScenarioSpec& spec);

/// The goals of the scenario's agents, each once (m), with the largest goal radius used there.
struct GoalMark {
    ch::Vec2 position{0, 0};
    double radius = 0;
};
std::vector<GoalMark> goalMarks(const ch::ScenarioSpec& spec);

/// The value each active agent is coloured by (index = AgentStore index): density measured with
/// Poly6 (h = 1 m, walls included, as in metrics.csv), |contact acceleration| (m/s²), or the
/// panic/injury fields; zeros for None. Calls sim.measureDensity() for Density.
std::vector<double> agentValues(ch::Simulation& sim, Colouring c);

}  // namespace chrender
