// CrowdHealth — private helpers of the XML loader (xml*.cpp). Not installed, not public.
//
// The loader is split by topic: xml.cpp (documents, files, <Simulation>, <World>, <Output>,
// final checks), xml_policies.cpp, xml_agents.cpp and xml_obstacles.cpp. Every element is read
// through an ElementReader, which checks the attribute names against the element's ParamTable
// (so unknown attributes, ranges and units are reported the same way everywhere) and records every
// problem in the shared Diagnostics instead of stopping.
#pragma once

#include "crowdhealth/io/diagnostics.h"
#include "crowdhealth/core/params.h"
#include "crowdhealth/core/scenario.h"

#include <tinyxml2.h>

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace ch::xmlio {

using tinyxml2::XMLElement;

/// State shared by every part of one load.
struct LoadContext {
    LoadContext(Diagnostics& d, ScenarioSpec& s) : diags(d), spec(s) {}
    Diagnostics& diags;
    ScenarioSpec& spec;
    /// Index of the next generator (<AgentGrid>, <SpawnRectangle>) in file order: it selects the
    /// generator's random stream so its agents depend only on the seed and the file.
    std::uint64_t generatorCount = 0;

    /// One entry per element of spec.agents, in the same order.
    struct AgentOrigin {
        bool explicitId = false;
        SourceLoc idLoc;
    };
    std::vector<AgentOrigin> agentOrigins;

    /// A `<Policy id>` reference of an agent or generator, checked once everything is loaded.
    struct PolicyRef {
        int id = 0;
        SourceLoc loc;
    };
    std::vector<PolicyRef> policyRefs;
    /// Every policy id declared, valid or not (so a broken policy does not also make every agent
    /// that uses it an error).
    std::map<int, SourceLoc> policyIds;
    /// Journey names written by agents and generators (empty: none), checked once the venue is loaded.
    struct JourneyRef {
        std::string name;
        SourceLoc loc;
    };
    std::vector<JourneyRef> journeyRefs;
    /// Where each venue element stands, by kind and name, for messages of the final checks.
    std::map<std::string, SourceLoc> venueLocs;
    /// A <Policies>/<Agents> file could not be read: skip the checks that would only repeat that.
    bool policiesIncomplete = false;
    /// A <Plugin> could not be loaded (its components are then unknown: said in that message).
    bool pluginFailed = false;
    bool agentsIncomplete = false;
};

/// Case-insensitive element-name test (UMANS files mix "costfunction" and "CostFunction").
bool is(const XMLElement* el, const char* name);
/// Location of an element.
SourceLoc locOf(const std::string& file, const XMLElement* el);
/// Reports a child element that is not allowed where it stands: "unknown element" with a
/// suggestion from `allowed`, or where the element belongs.
/// An empty `parent` means the top level of a file.
void reportUnexpectedElement(LoadContext& ctx, const std::string& file, const XMLElement* child,
                             const std::string& parent, const std::vector<std::string>& allowed);
/// True for planned-but-unimplemented extension elements (and reports them); none at present.
bool reportIfUnsupported(LoadContext& ctx, const std::string& file, const XMLElement* el);

/// Reads the attributes of one element against its parameter table.
class ElementReader {
public:
    /// Reports every attribute not in `table` or `extras` (with a suggestion) and any stray text.
    ElementReader(LoadContext& ctx, std::string file, const XMLElement* el, std::string display,
                  const ParamTable& table, std::vector<std::string> extras = {});

    const std::string& file() const { return file_; }
    const XMLElement* element() const { return el_; }
    const std::string& display() const { return display_; }
    SourceLoc loc() const { return locOf(file_, el_); }
    /// The attribute's own line (the element's when absent).
    SourceLoc loc(const std::string& attr) const;

    bool has(const std::string& attr) const { return el_->Attribute(attr.c_str()) != nullptr; }
    /// Raw text of an attribute (nullopt when absent).
    std::optional<std::string> text(const std::string& attr) const;

    /// Parsed value of a table attribute; nullopt when absent or invalid (invalid is reported).
    std::optional<double> optional(const std::string& attr);
    /// As optional(), and reports "missing required value" when absent.
    std::optional<double> required(const std::string& attr);
    /// Parsed value, or the table default when absent or invalid.
    double value(const std::string& attr);
    const ParamSpec& spec(const std::string& attr) const;

    /// Reports an error about this element and remembers that it is broken.
    void error(const SourceLoc& where, const std::string& message);
    /// True when any problem was reported through this reader.
    bool failed() const { return failed_; }

private:
    LoadContext& ctx_;
    std::string file_;
    const XMLElement* el_;
    std::string display_;
    const ParamTable& table_;
    bool failed_ = false;
};

/// Reads a `<pos>`, `<goal>` or `<Point>` element: required x and y in metres.
std::optional<Vec2> readPoint(LoadContext& ctx, const std::string& file, const XMLElement* el,
                              const std::string& display);
/// Reads an agent's or generator's `<Policy id>` child and records the reference.
std::optional<int> readPolicyRef(LoadContext& ctx, const std::string& file, const XMLElement* el);
/// Adds an agent produced by an element or generator (id still to be assigned).
void addAgent(LoadContext& ctx, AgentSpec agent, bool explicitId, const SourceLoc& idLoc);
/// Makes room for `more` agents to be added (a generator that knows its count): exact for the
/// first large generator, geometric growth when several follow one another.
void reserveAgents(LoadContext& ctx, std::size_t more);

// Element readers, one per topic file.
void readPolicy(LoadContext& ctx, const std::string& file, const XMLElement* el);
/// Once obstacles and policies are loaded: resolves SPH@walls where the file is silent and warns
/// where it contradicts the obstacles (xml_policies.cpp).
void checkWallModels(LoadContext& ctx);
void readAgent(LoadContext& ctx, const std::string& file, const XMLElement* el);
void readAgentGrid(LoadContext& ctx, const std::string& file, const XMLElement* el);
void readSpawnRectangle(LoadContext& ctx, const std::string& file, const XMLElement* el);
/// True for a name ending in .dxf or .wkt (any case): venue geometry rather than an XML file.
bool isGeometryFile(const std::string& name);
/// `<Obstacles file="venue.dxf|room.wkt" scale>` with its `<Layer>` children (xml_geometry.cpp,
/// docs/geometry.md). `r` reads the <Obstacles> element (its `scale` attribute).
void readGeometryFile(LoadContext& ctx, const std::string& file, const XMLElement* el, ElementReader& r,
                      const std::string& name);
void readObstacle(LoadContext& ctx, const std::string& file, const XMLElement* el);
void readBox(LoadContext& ctx, const std::string& file, const XMLElement* el);
/// Venue elements (xml_venue.cpp): <Navigation>, <Target>, <Exit>, <ExitSet>, <Journey> in
/// <World>; <Source> in <Agents>; <CloseExit>/<OpenExit> in <Schedule>.
void readNavigation(LoadContext& ctx, const std::string& file, const XMLElement* el);
void readTarget(LoadContext& ctx, const std::string& file, const XMLElement* el, bool exit);
void readExitSet(LoadContext& ctx, const std::string& file, const XMLElement* el);
void readJourney(LoadContext& ctx, const std::string& file, const XMLElement* el);
void readSource(LoadContext& ctx, const std::string& file, const XMLElement* el);
void readExitEvent(LoadContext& ctx, const std::string& file, const XMLElement* el, bool open);
/// <Measurement interval> in <Simulation>: <Line> and <Area> children (xml_venue.cpp).
void readMeasurement(LoadContext& ctx, const std::string& file, const XMLElement* el);
/// Once everything is loaded: names resolve, exits are exits, targets touch walkable floor and
/// every agent can reach the targets of its journey (xml_venue.cpp). Then expands the sources.
void checkVenue(LoadContext& ctx);
/// <CrowdHealth> inside a <Policy> (xml_schedule.cpp).
void readCrowdHealth(LoadContext& ctx, const std::string& file, const XMLElement* el, PolicySpec& policy);
/// <Schedule> inside <Simulation>: <Ramp> and <PanicEvent> children (xml_schedule.cpp).
void readSchedule(LoadContext& ctx, const std::string& file, const XMLElement* el);
/// Checks that need every policy: ramp targets exist (xml_schedule.cpp).
void checkSchedule(LoadContext& ctx);

}  // namespace ch::xmlio
