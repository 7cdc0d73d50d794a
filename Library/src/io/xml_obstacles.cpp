// CrowdHealth — XML loader: <Obstacle> polygons (UMANS) and <Box> walls (CrowdHealth).
#include "xml_internal.h"

#include <algorithm>
#include <cmath>

namespace ch::xmlio {

namespace {

const ParamTable& boxTable() {
    static const ParamTable t = [] {
        ParamTable table = {
            ParamSpec::real("x", "m", 0, -1e300, 1e300, "x of the lower-left corner"),
            ParamSpec::real("y", "m", 0, -1e300, 1e300, "y of the lower-left corner"),
            ParamSpec::real("width", "m", 0, 0, 1e300, "extent along x"),
            ParamSpec::real("height", "m", 0, 0, 1e300, "extent along y"),
            ParamSpec::boolean("particles", false, "pack static SPH boundary particles inside (the paper's walls)"),
            // 0.48 m = two default agent radii: boundary particles as dense as a packed crowd.
            ParamSpec::real("spacing", "m", 0.48, 0, 1e300, "distance between boundary particles"),
        };
        table[2].minExclusive = table[3].minExclusive = table[5].minExclusive = true;
        return table;
    }();
    return t;
}

/// Particle count limit per box, so a tiny spacing fails cleanly instead of exhausting memory.
constexpr double kMaxParticles = 1e7;

}  // namespace

void readObstacle(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    static const ParamTable none;
    ElementReader r(ctx, file, el, "Obstacle", none);
    ObstacleSpec obstacle;
    obstacle.loc = r.loc();
    int pointElements = 0;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (!is(c, "Point")) {
            reportUnexpectedElement(ctx, file, c, el->Name(), {"Point"});
            continue;
        }
        ++pointElements;
        if (std::optional<Vec2> p = readPoint(ctx, file, c, "Point")) obstacle.points.push_back(*p);
    }
    if (pointElements < 2) {
        r.error(r.loc(), "Obstacle: needs at least 2 <Point> elements, found " + std::to_string(pointElements));
        return;
    }
    if (!r.failed() && obstacle.points.size() == static_cast<std::size_t>(pointElements))
        ctx.spec.obstacles.push_back(std::move(obstacle));
}

void readBox(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "Box", boxTable());
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    const auto x = r.required("x"), y = r.required("y");
    const auto w = r.required("width"), h = r.required("height");
    const bool particles = r.value("particles") != 0.0;
    const double spacing = r.value("spacing");
    if (!x || !y || !w || !h || r.failed()) return;

    ObstacleSpec box;
    box.loc = r.loc();
    // Counter-clockwise, so the edges' outward normals point away from the box.
    box.points = {Vec2(*x, *y), Vec2(*x + *w, *y), Vec2(*x + *w, *y + *h), Vec2(*x, *y + *h)};
    if (particles) {
        // Cell centres of a spacing × spacing grid; a remainder narrower than one cell is shared
        // equally by both sides so the particles sit symmetrically in the wall (at least one cell
        // per direction, so a wall thinner than `spacing` still gets a row of particles).
        const double nx = std::max(1.0, std::floor(*w / spacing + 1e-9));
        const double ny = std::max(1.0, std::floor(*h / spacing + 1e-9));
        if (nx * ny > kMaxParticles) {
            r.error(r.loc("spacing"), "Box@spacing: " + *r.text("spacing") + " m would create more than 10000000 particles");
            return;
        }
        const double x0 = *x + 0.5 * (*w - nx * spacing) + 0.5 * spacing;
        const double y0 = *y + 0.5 * (*h - ny * spacing) + 0.5 * spacing;
        for (int j = 0; j < static_cast<int>(ny); ++j)
            for (int i = 0; i < static_cast<int>(nx); ++i) box.particles.emplace_back(x0 + i * spacing, y0 + j * spacing);
    }
    ctx.spec.obstacles.push_back(std::move(box));
}

}  // namespace ch::xmlio
