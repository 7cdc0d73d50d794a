// Prints a libFuzzer dictionary for the scenario loader: every element name the loader knows,
// every registered component with its parameters, and the attributes of the parameter tables
// the library exposes (<Safety>, <CrowdHealth>), as "token" lines. scripts/fuzz.sh runs it.
#include "crowdhealth/health/health.h"
#include "crowdhealth/core/registry.h"
#include "crowdhealth/health/safety.h"

#include <iostream>
#include <set>
#include <string>

int main() {
    std::set<std::string> tokens;
    for (const char* e : {"Simulation", "World", "Obstacles", "Obstacle", "Point", "Box", "Policies", "Policy",
                          "Step", "costfunction", "CostFunction", "CrowdHealth", "Agents", "Agent", "pos", "goal",
                          "color", "AgentGrid", "SpawnRectangle", "Output", "Safety", "Schedule", "Ramp",
                          "PanicEvent", "Navigation", "Target", "Exit", "ExitSet", "Journey", "Waypoint", "Source",
                          "Rate", "Draw", "CloseExit", "OpenExit", "Layer"}) {
        tokens.insert("<" + std::string(e));
        tokens.insert("</" + std::string(e) + ">");
    }
    for (const char* a : {"delta_time", "delta_time_fine", "end_time", "seed", "type", "width", "height", "xmin",
                          "xmax", "ymin", "ymax", "file", "id", "name", "coeff", "range", "rad", "pref_speed",
                          "max_speed", "max_acceleration", "mass", "remove_at_goal", "start_time", "goal_radius",
                          "x", "y", "r", "g", "b", "OptimizationMethod", "RelaxationTime", "ContactForceScale",
                          "DeltaTime", "StopAtGoal", "BlendField", "BlendFrom", "BlendTo", "particles", "spacing",
                          "columns", "rows", "rad_min", "rad_max", "policy", "component", "parameter", "from", "to",
                          "start", "end", "agents", "time", "radius", "strength", "trajectories",
                          "trajectory_interval", "metrics_interval", "NrAgentsHorizontal", "NrAgentsVertical",
                          "cell_size", "clearance", "min_speed", "margin", "exits", "weights", "fixed", "choice",
                          "interval", "hysteresis", "flow_capacity", "leave_by", "target", "dwell", "capacity",
                          "rate", "count", "journey", "premovement", "attribute", "distribution", "value", "min",
                          "max", "mean", "sd", "exit", "as", "scale", "prefix"})
        tokens.insert(std::string(a) + "=\"");
    for (const ch::ComponentInfo* info : ch::Registry::instance().all()) {
        tokens.insert("\"" + info->name + "\"");
        for (const ch::ParamSpec& p : ch::Registry::fullTable(*info)) tokens.insert(p.name + "=\"");
    }
    for (const ch::ParamSpec& p : ch::safetyTable()) tokens.insert(p.name + "=\"");
    for (const ch::ParamSpec& p : ch::crowdHealthTable()) tokens.insert(p.name + "=\"");
    for (const char* v : {"\"Infinite\"", "\"Toric\"", "\"Planar\"", "\"gradient\"", "\"sampling\"", "\"global\"",
                          "\"fine\"", "\"coarse\"", "\"nearest\"", "\"quickest\"", "\"weighted\"",
                          "\"uniform\"", "\"normal\"", "\"constant\"", "\"pref_speed\"", "\"true\"", "\"false\"", "\"auto\"", "\"nan\"", "\"1e308\"",
                          "\"-1\"", "\"0\"", "/>", "<?xml version=\"1.0\"?>", "<!--", "-->", "\n--FILE--\n",
                          "\"inc1.xml\"", "\"inc2.xml\"", "\"inc3.xml\"", "\"main.xml\"", "\"inc1.dxf\"", "\"inc1.wkt\"",
                          // <Layer as="…"> of <Obstacles file="….dxf"> (docs/geometry.md)
                          "\"wall\"", "\"boundary\"", "\"exit\"", "\"target\"", "\"line\"", "\"area\"",
                          "\"ignore\"",
                          // the files themselves: DXF group pairs and WKT words
                          "0\nSECTION\n2\nENTITIES\n", "0\nENDSEC\n0\nEOF\n", "0\nLINE\n8\n0\n10\n", "0\nLWPOLYLINE\n",
                          "0\nPOLYLINE\n", "0\nVERTEX\n", "0\nSEQEND\n", "0\nARC\n", "0\nCIRCLE\n", "\n90\n",
                          "\n70\n1\n", "\n42\n", "\n5\n2F\n", "$INSUNITS", "POLYGON ((", "MULTIPOLYGON (((", "EMPTY"})
        tokens.insert(v);
    for (const std::string& t : tokens) {
        std::cout << '"';
        for (const char c : t) {
            // libFuzzer's dictionary syntax: \\, \" and \xHH escapes, printable ASCII otherwise.
            const auto u = static_cast<unsigned char>(c);
            if (c == '"' || c == '\\') std::cout << '\\' << c;
            else if (u < 0x20 || u >= 0x7f) std::cout << "\\x" << "0123456789ABCDEF"[u >> 4] << "0123456789ABCDEF"[u & 15];
            else std::cout << c;
        }
        std::cout << "\"\n";
    }
}
