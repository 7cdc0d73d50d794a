// CrowdHealth — XML loader: venue geometry from the files people have (docs/geometry.md).
// <Obstacles file="venue.dxf" scale="…"> <Layer name as prefix/>… </Obstacles> reads a DXF drawing
// with dxflib; <Obstacles file="room.wkt" scale="…"/> reads a WKT POLYGON or MULTIPOLYGON (the
// walkable area, as JuPedSim and shapely users write it) with the small strict parser below.
//
// DXF: dxflib decodes the entities; a pre-scan of our own first checks the file's structure (group
// code/value pairs, numbers, the counts dxflib allocates from, sections, the final EOF) so that a
// truncated or foreign file gets one clear message with its line instead of silently wrong
// geometry, and it finds $INSUNITS and the entities CrowdHealth does not read. During dxflib's pass
// we count the group pairs to know the line of each entity (dxflib reports none).
#include "xml_internal.h"

#include "crowdhealth/core/geometry.h"
#include "crowdhealth/io/output.h"

#include <dl_creationadapter.h>
#include <dl_dxf.h>

#include <algorithm>
#include <charconv>
#include <clocale>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

namespace ch::xmlio {

namespace {

/// Largest distance (m) between an arc or circle and the chords that replace it.
constexpr double kChordError = 0.01;
/// Most segments one arc or circle becomes.
constexpr int kMaxArcSegments = 1024;
/// Most vertices dxflib is asked to allocate for one entity (LWPOLYLINE, SPLINE, …).
constexpr long kMaxCount = 1000000;

enum class Role { Wall, Boundary, Exit, Target, Line, Area, Ignore };
const std::vector<std::string>& roleWords() {
    static const std::vector<std::string> w = {"wall", "boundary", "exit", "target", "line", "area", "ignore"};
    return w;
}

const ParamTable& layerTable() {
    static const ParamTable t = {
        ParamSpec::choice("as", roleWords(), 0, "what the layer's entities become"),
    };
    return t;
}

std::string upperAscii(std::string s) {
    for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return s;
}

std::string trim(const std::string& s) {
    std::size_t b = 0, e = s.size();
    while (b < e && (s[b] == ' ' || s[b] == '\t')) ++b;
    while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r' || s[e - 1] == '\n')) --e;
    return s.substr(b, e - b);
}

/// A name usable as a target or measurement id: no spaces, commas or quotes (they become '_').
std::string idSafe(std::string s) {
    for (char& c : s)
        if (c == ' ' || c == '\t' || c == ',' || c == '"') c = '_';
    return s;
}

std::string shortText(std::string s) {
    if (s.size() > 40) s = s.substr(0, 37) + "...";
    return s;
}

/// One layer mapping of <Obstacles>: `<Layer name as prefix/>`.
struct LayerRule {
    std::string name;
    Role role = Role::Wall;
    std::string prefix;  ///< names of targets/exits/lines/areas: PREFIX-1, PREFIX-2, …
    SourceLoc loc;
    int made = 0;        ///< items named so far
    bool seen = false;   ///< an entity of the drawing is on this layer
};

/// A drawn shape in drawing units: a polyline (open or closed), with where it came from.
struct Shape {
    std::vector<Vec2> pts;
    bool closed = false;
    std::string type;    ///< "LINE", "LWPOLYLINE", … ("POLYGON ring" for WKT)
    std::string handle;  ///< DXF handle (hex), may be empty
    std::string layer;
    SourceLoc loc;
    std::string describe() const {
        std::string s = "entity " + type;
        if (!handle.empty()) s += " handle " + handle;
        s += " on layer '" + layer + "'";
        return s;
    }
};

/// Points of the arc of centre c and radius r from angle a0 over `sweep` radians (signed), both
/// ends included, with chords at most `tol` from the arc (in the same units).
std::vector<Vec2> arcPoints(const Vec2& c, double r, double a0, double sweep, double tol, int minSegments) {
    const double half = std::acos(std::clamp(1.0 - tol / r, -1.0, 1.0));  // half the angle of one chord
    int n = half > 0 ? static_cast<int>(std::ceil(std::abs(sweep) / (2.0 * half) - 1e-9)) : kMaxArcSegments;
    n = std::clamp(n, minSegments, kMaxArcSegments);
    std::vector<Vec2> pts;
    pts.reserve(static_cast<std::size_t>(n) + 1);
    for (int k = 0; k <= n; ++k) {
        const double a = a0 + sweep * k / n;
        pts.emplace_back(c.x() + r * std::cos(a), c.y() + r * std::sin(a));
    }
    return pts;
}

/// Drops vertices equal to their predecessor (and, for a closed shape, a last vertex equal to the first).
void dropRepeats(std::vector<Vec2>& pts, bool closed) {
    std::vector<Vec2> out;
    for (const Vec2& p : pts)
        if (out.empty() || (p - out.back()).norm() > 1e-12) out.push_back(p);
    if (closed) while (out.size() > 1 && (out.back() - out.front()).norm() <= 1e-12) out.pop_back();
    pts = std::move(out);
}

/// Turns shapes into obstacles, targets, measurement lines and areas (coordinates already in metres).
class ShapeSink {
public:
    ShapeSink(LoadContext& ctx, std::string file) : ctx_(ctx), file_(std::move(file)) {}

    int used() const { return used_; }

    void add(Shape s, Role role, LayerRule* rule) {
        dropRepeats(s.pts, s.closed);
        if (role == Role::Ignore) return;
        if (s.pts.size() < 2) {
            ctx_.diags.warning(s.loc, s.describe() + ": fewer than two distinct points; ignored");
            return;
        }
        // A polygon for exits, targets and areas: a closed shape, or an open one that returns to its
        // first point (drawn closed without the closed flag).
        const auto polygon = [&](const char* what) -> std::optional<std::vector<Vec2>> {
            std::vector<Vec2> p = s.pts;
            if (!s.closed) {
                if (p.size() >= 4 && (p.back() - p.front()).norm() <= 1e-9 * std::max(1.0, p.front().norm())) {
                    p.pop_back();
                } else {
                    ctx_.diags.error(s.loc, s.describe() + ": " + what + " must be a closed polyline or a circle (this " +
                                                "one is open: set its closed flag, or draw it on a line layer)");
                    return std::nullopt;
                }
            }
            if (p.size() < 3 || !(std::abs(polygonArea(p)) > 0)) {
                ctx_.diags.error(s.loc, s.describe() + ": " + what + " has no area");
                return std::nullopt;
            }
            return p;
        };
        switch (role) {
            case Role::Wall:
                if (s.closed && s.pts.size() >= 3 && std::abs(polygonArea(s.pts)) > 0) {
                    ObstacleSpec o;
                    o.points = s.pts;
                    o.loc = s.loc;
                    ctx_.spec.obstacles.push_back(std::move(o));
                    ++used_;
                } else {
                    segments(s);
                }
                return;
            case Role::Boundary:
                segments(s);
                return;
            case Role::Exit:
            case Role::Target: {
                const bool exit = role == Role::Exit;
                const auto p = polygon(exit ? "an exit" : "a target");
                if (!p) return;
                TargetSpec t;
                t.name = nextName(rule, s);
                t.exit = exit;
                t.shape.kind = TargetShape::Kind::Polygon;
                t.shape.polygon = *p;
                t.loc = s.loc;
                if (!remember("target:" + t.name, s)) return;
                ctx_.spec.venue.targets.push_back(std::move(t));
                ++used_;
                return;
            }
            case Role::Line: {
                if (s.closed) {
                    ctx_.diags.error(s.loc, s.describe() + ": a measurement line must be a LINE or an open polyline "
                                                           "(a closed shape belongs on an area layer)");
                    return;
                }
                for (std::size_t k = 0; k + 1 < s.pts.size(); ++k) {
                    MeasureLineSpec l;
                    l.name = nextName(rule, s);
                    l.a = s.pts[k];
                    l.b = s.pts[k + 1];
                    l.loc = s.loc;
                    if (!remember("measurement:" + l.name, s)) return;
                    ctx_.spec.measurement.lines.push_back(std::move(l));
                    ++used_;
                }
                return;
            }
            case Role::Area: {
                const auto p = polygon("a measurement area");
                if (!p) return;
                MeasureAreaSpec a;
                a.name = nextName(rule, s);
                a.polygon = *p;
                a.loc = s.loc;
                if (!remember("measurement:" + a.name, s)) return;
                ctx_.spec.measurement.areas.push_back(std::move(a));
                ++used_;
                return;
            }
            case Role::Ignore: return;
        }
    }

    /// One two-point obstacle (a wall segment) per edge; the closing edge only when closed.
    void segments(const Shape& s) {
        const std::size_t n = s.pts.size();
        const std::size_t edges = s.closed && n >= 3 ? n : n - 1;
        for (std::size_t k = 0; k < edges; ++k) {
            ObstacleSpec o;
            o.points = {s.pts[k], s.pts[(k + 1) % n]};
            o.loc = s.loc;
            ctx_.spec.obstacles.push_back(std::move(o));
        }
        ++used_;
    }

private:
    std::string nextName(LayerRule* rule, const Shape& s) {
        const std::string prefix = rule != nullptr ? rule->prefix : idSafe(s.layer);
        const int k = rule != nullptr ? ++rule->made : ++unnamed_;
        return prefix + "-" + std::to_string(k);
    }

    bool remember(const std::string& key, const Shape& s) {
        auto [it, inserted] = ctx_.venueLocs.emplace(key, s.loc);
        if (!inserted) {
            const std::string kind = key.substr(0, key.find(':')), name = key.substr(key.find(':') + 1);
            ctx_.diags.error(s.loc, s.describe() + ": duplicate " + kind + " name '" + name + "' (first defined at " +
                                        it->second.file + ":" + std::to_string(it->second.line) +
                                        "); give the layer another prefix=\"…\"");
        }
        return inserted;
    }

    LoadContext& ctx_;
    std::string file_;
    int used_ = 0;
    int unnamed_ = 0;
};

// ---------------------------------------------------------------------------------------------
// DXF

/// What the pre-scan learnt.
struct DxfScan {
    std::optional<int> insunits;                 ///< $INSUNITS of the header
    /// Entities of the ENTITIES section that CrowdHealth does not read: type, layer, line.
    struct Unread {
        std::string type, layer;
        int line = 0;
    };
    std::vector<Unread> unsupported;
    std::set<std::string> layers;                ///< layers of the entities (upper case)
    std::map<std::string, std::string> layerSpelling;  ///< upper case → as written
};

bool parseReal(const std::string& s, double& v) {
    const char* b = s.data();
    const char* e = s.data() + s.size();
    if (b != e && *b == '+') ++b;
    const auto r = std::from_chars(b, e, v);
    return b != e && r.ec == std::errc() && r.ptr == e && std::isfinite(v);
}

bool parseInt(const std::string& s, long& v) {
    const char* b = s.data();
    const char* e = s.data() + s.size();
    if (b != e && *b == '+') ++b;
    const auto r = std::from_chars(b, e, v);
    return b != e && r.ec == std::errc() && r.ptr == e;
}

/// Checks the structure of a text DXF file (see the top of this file). False: reported.
bool scanDxf(LoadContext& ctx, const std::string& path, const std::string& content, DxfScan& scan) {
    const auto fail = [&](int line, const std::string& msg) {
        ctx.diags.error(SourceLoc{path, line}, msg);
        return false;
    };
    if (content.empty()) return fail(1, "the file is empty: not a DXF drawing");
    if (content.rfind("AutoCAD Binary DXF", 0) == 0)
        return fail(1, "binary DXF is not supported: save the drawing as ASCII (text) DXF");
    for (const char ch : content) {
        const auto c = static_cast<unsigned char>(ch);
        if (c < 0x20 && c != '\t' && c != '\n' && c != '\r')
            return fail(1, "not a text file (it holds control characters): not an ASCII DXF drawing");
    }
    std::vector<std::string> lines;
    {
        std::size_t start = 0;
        while (start < content.size()) {
            std::size_t end = content.find('\n', start);
            if (end == std::string::npos) end = content.size();
            lines.push_back(content.substr(start, end - start));
            start = end + 1;
        }
    }
    for (std::size_t i = 0; i < lines.size(); ++i)
        if (lines[i].size() > 1000)
            return fail(static_cast<int>(i + 1), "line longer than 1000 characters: not a DXF drawing (dxflib reads at most 1023)");

    std::string section;          // current section name, "" outside
    bool sectionNamePending = false, sawEntities = false, eof = false, firstGroup = true;
    std::string entity;           // type of the current entity record (ENTITIES/BLOCKS), "" otherwise
    std::string entityLayer = "0";
    int entityLine = 0, lwVertices = 0;
    long lwDeclared = -1;
    std::string headerVar;
    static const std::set<std::string> supported = {"LINE", "LWPOLYLINE", "POLYLINE", "VERTEX", "SEQEND", "ARC", "CIRCLE"};
    const auto endEntity = [&]() -> bool {
        if (entity == "LWPOLYLINE") {
            if (lwDeclared < 0) return fail(entityLine, "LWPOLYLINE without its vertex count (group 90): a broken DXF entity");
            if (lwDeclared != lwVertices)
                return fail(entityLine, "LWPOLYLINE declares " + std::to_string(lwDeclared) + " vertices (group 90) but holds " +
                                            std::to_string(lwVertices) + ": a broken DXF entity");
        }
        if (section == "ENTITIES" && !entity.empty() && supported.count(entity) == 0)
            scan.unsupported.push_back({entity, entityLayer, entityLine});
        entity.clear();
        return true;
    };
    std::size_t i = 0;
    for (; i + 1 < lines.size() || (i < lines.size() && !trim(lines[i]).empty()); i += 2) {
        const int line = static_cast<int>(i + 1);
        const std::string codeText = trim(lines[i]);
        long code = 0;
        if (!parseInt(codeText, code) || code < 0 || code > 1071) {
            if (firstGroup) return fail(line, "not a DXF drawing: it must start with group code 0 and SECTION, found '" + shortText(codeText) + "'");
            return fail(line, "'" + shortText(codeText) + "' is not a DXF group code (a whole number from 0 to 1071 on its own line): the file is broken or not DXF");
        }
        if (i + 1 >= lines.size()) return fail(line, "the file ends after a group code without its value: truncated");
        const std::string value = trim(lines[i + 1]);
        if (firstGroup && code != 999) {
            if (code != 0 || value != "SECTION")
                return fail(line, "not a DXF drawing: it must start with group code 0 and SECTION, found " + std::to_string(code) + " '" + shortText(value) + "'");
            firstGroup = false;
        }
        if (code == 999) continue;
        if (code == 0) {
            if (!endEntity()) return false;
            if (value == "EOF") {
                if (!section.empty()) return fail(line, "EOF inside section " + section + " (no ENDSEC): truncated or broken");
                eof = true;
                break;
            }
            if (value == "SECTION") {
                if (!section.empty()) return fail(line, "SECTION inside section " + section + " (no ENDSEC before it): broken DXF");
                sectionNamePending = true;
                continue;
            }
            if (value == "ENDSEC") {
                if (section.empty()) return fail(line, "ENDSEC outside a section: broken DXF");
                section.clear();
                continue;
            }
            if (section.empty()) return fail(line, "'" + shortText(value) + "' outside a section: broken DXF");
            if (section == "ENTITIES" || section == "BLOCKS") {
                entity = value;
                entityLine = line;
                lwVertices = 0;
                lwDeclared = -1;
                entityLayer = "0";
            }
            continue;
        }
        if (sectionNamePending) {
            if (code != 2) return fail(line, "SECTION without its name (group code 2): broken DXF");
            section = value;
            sectionNamePending = false;
            if (section == "ENTITIES") sawEntities = true;
            continue;
        }
        if (section == "HEADER") {
            if (code == 9) headerVar = value;
            else if (headerVar == "$INSUNITS" && code == 70) {
                long v = 0;
                if (parseInt(value, v)) scan.insunits = static_cast<int>(v);
            }
            continue;
        }
        if (entity.empty()) continue;
        // Inside an entity record: numbers must be numbers, and counts must be sane.
        if ((code >= 10 && code <= 59) || (code >= 210 && code <= 239)) {
            double v = 0;
            if (!parseReal(value, v))
                return fail(line + 1, entity + " (at line " + std::to_string(entityLine) + "): group " + std::to_string(code) +
                                          " must be a number, found '" + shortText(value) + "'");
        } else if ((code >= 60 && code <= 99) || (code >= 170 && code <= 179)) {
            long v = 0;
            if (!parseInt(value, v) || v < -2147483647L || v > 2147483647L)
                return fail(line + 1, entity + " (at line " + std::to_string(entityLine) + "): group " + std::to_string(code) +
                                          " must be a whole number, found '" + shortText(value) + "'");
            const bool count = (entity == "LWPOLYLINE" && code == 90) ||
                               (entity == "SPLINE" && (code == 72 || code == 73 || code == 74)) ||
                               (entity == "LEADER" && code == 76) ||
                               (entity == "HATCH" && (code == 91 || code == 93 || code == 95 || code == 96 || code == 98));
            if (count && (v < 0 || v > kMaxCount))
                return fail(line + 1, entity + " (at line " + std::to_string(entityLine) + "): group " + std::to_string(code) + " count " +
                                          value + " is out of range (0 to " + std::to_string(kMaxCount) + ")");
            if (entity == "LWPOLYLINE" && code == 90) lwDeclared = v;
        }
        if (entity == "LWPOLYLINE" && code == 10) ++lwVertices;
        if (code == 8) entityLayer = value;
        if (code == 8 && section == "ENTITIES") {
            const std::string up = upperAscii(value);
            scan.layers.insert(up);
            scan.layerSpelling.emplace(up, value);
        }
    }
    if (!eof) {
        const int last = static_cast<int>(lines.size());
        return fail(last, "the file ends without the closing '0' 'EOF' group: truncated" +
                              std::string(section.empty() ? "" : " (inside section " + section + ")"));
    }
    if (!sawEntities) return fail(1, "the drawing has no ENTITIES section: nothing to read");
    return true;
}

/// Receives dxflib's entities and turns them into shapes (drawing units).
class DxfCollector : public DL_CreationAdapter {
public:
    struct Info {
        std::string type, handle, layer = "0", section;
        int line = 0;
    };

    DxfCollector(LoadContext& ctx, std::string path, double tol) : ctx_(ctx), path_(std::move(path)), tol_(tol) {}

    std::vector<Shape> shapes;
    std::set<std::string> layers;  ///< upper-case layers of shapes read

    void processCodeValuePair(unsigned int code, const std::string& value) override {
        const int line = 2 * groups_ + 1;
        ++groups_;
        if (afterEof_) {
            ignore_ = true;
            return;
        }
        if (code == 0) {
            pending_ = current_;
            current_ = Info{};
            current_.type = value;
            current_.line = line;
            current_.section = section_;
            if (value == "SECTION") sectionNext_ = true;
            else if (value == "ENDSEC") section_.clear();
            else if (value == "EOF") afterEof_ = true;
        } else if (code == 2 && sectionNext_) {
            section_ = value;
            sectionNext_ = false;
        } else if (code == 5) {
            current_.handle = value;
        } else if (code == 8) {
            current_.layer = value;
        }
    }

    void addLine(const DL_LineData& d) override {
        if (!take()) return;
        Shape s = shapeOf(pending_);
        s.pts = {Vec2(d.x1, d.y1), Vec2(d.x2, d.y2)};
        push(std::move(s));
    }

    void addArc(const DL_ArcData& d) override {
        double a0 = d.angle1 * M_PI / 180.0, a1 = d.angle2 * M_PI / 180.0;
        double sweep = std::fmod(a1 - a0, 2 * M_PI);
        if (sweep <= 0) sweep += 2 * M_PI;
        addCurve(Vec2(d.cx, d.cy), d.radius, a0, sweep, false);
    }

    void addCircle(const DL_CircleData& d) override { addCurve(Vec2(d.cx, d.cy), d.radius, 0, 2 * M_PI, true); }

    /// An ARC (open) or a CIRCLE (closed) as chords: the entity's shape, mirrored when its
    /// extrusion points down.
    void addCurve(const Vec2& centre, double radius, double a0, double sweep, bool circle) {
        if (!take()) return;
        Shape s = shapeOf(pending_);
        bool mirror = false;
        if (!planView(s, mirror)) return;
        if (!(radius > 0)) {
            ctx_.diags.warning(s.loc, s.describe() + ": radius " + formatNumber(radius) + " is not positive; ignored");
            return;
        }
        s.pts = arcPoints(centre, radius, a0, sweep, tol_, circle ? 8 : 1);
        if (circle) {
            s.pts.pop_back();  // the last point repeats the first
            s.closed = true;
        }
        if (mirror) for (Vec2& p : s.pts) p.x() = -p.x();
        push(std::move(s));
    }

    void addPolyline(const DL_PolylineData& d) override {
        finishPolyline();
        if (!take()) return;
        poly_ = shapeOf(pending_);
        poly_->closed = (d.flags & 1) != 0;
        polyMirror_ = false;
        if ((d.flags & (16 | 64)) != 0) {
            ctx_.diags.warning(poly_->loc, poly_->describe() + ": a polygon or polyface mesh, not a plan outline; ignored");
            poly_.reset();
            return;
        }
        if ((d.flags & 8) == 0 && !planView(*poly_, polyMirror_)) {  // 2-D polylines lie in their OCS
            poly_.reset();
            return;
        }
        vertices_.clear();
    }

    void addVertex(const DL_VertexData& d) override {
        if (poly_ && !ignore_) vertices_.push_back({Vec2(d.x, d.y), d.bulge});
    }

    void endEntity() override { finishPolyline(); }
    void endSequence() override { finishPolyline(); }

    void setVariableInt(const std::string&, int, int) override {}

    /// Flushes a polyline still open (a POLYLINE without SEQEND).
    void finish() { finishPolyline(); }

private:
    struct Vertex {
        Vec2 p;
        double bulge;
    };

    bool take() const { return !ignore_ && pending_.section == "ENTITIES" && !attributes.isInPaperSpace(); }

    Shape shapeOf(const Info& info) const {
        Shape s;
        s.type = info.type;
        s.handle = info.handle;
        s.layer = info.layer;
        s.loc = SourceLoc{path_, info.line};
        return s;
    }

    /// True when the entity lies in the plan (extrusion ±z); `mirror` for −z (x is mirrored).
    bool planView(const Shape& s, bool& mirror) {
        const double* n = getExtrusion()->getDirection();
        if (std::abs(n[0]) < 1e-9 && std::abs(n[1]) < 1e-9 && n[2] != 0) {
            mirror = n[2] < 0;
            return true;
        }
        ctx_.diags.warning(s.loc, s.describe() + ": drawn in a tilted plane (extrusion " + formatNumber(n[0]) + ", " +
                                      formatNumber(n[1]) + ", " + formatNumber(n[2]) + "), not in the plan; ignored");
        return false;
    }

    void finishPolyline() {
        if (!poly_) return;
        Shape s = std::move(*poly_);
        poly_.reset();
        const std::size_t n = vertices_.size();
        const std::size_t edges = s.closed ? n : (n == 0 ? 0 : n - 1);
        for (std::size_t k = 0; k < n; ++k) {
            s.pts.push_back(vertices_[k].p);
            const double b = vertices_[k].bulge;
            if (k >= edges || std::abs(b) < 1e-12 || !std::isfinite(b)) continue;
            const Vec2 p = vertices_[k].p, q = vertices_[(k + 1) % n].p;
            const double c = (q - p).norm();
            if (c <= 0) continue;
            // The arc from p to q whose included angle is 4·atan(bulge) (positive: counter-clockwise).
            const double sweep = 4.0 * std::atan(b);
            const double sag = b * c / 2.0;
            const double r = (c * c / 4.0 + sag * sag) / (2.0 * sag);  // signed
            const Vec2 d = (q - p) / c, left(-d.y(), d.x());
            const Vec2 centre = 0.5 * (p + q) + left * (r - sag);
            const double a0 = std::atan2(p.y() - centre.y(), p.x() - centre.x());
            std::vector<Vec2> arc = arcPoints(centre, std::abs(r), a0, sweep, tol_, 1);
            s.pts.insert(s.pts.end(), arc.begin() + 1, arc.end() - 1);  // the ends are the vertices
        }
        if (polyMirror_) for (Vec2& p : s.pts) p.x() = -p.x();
        vertices_.clear();
        push(std::move(s));
    }

    void push(Shape s) {
        for (const Vec2& p : s.pts)
            if (!std::isfinite(p.x()) || !std::isfinite(p.y())) {
                ctx_.diags.error(s.loc, s.describe() + ": a coordinate is not finite");
                return;
            }
        layers.insert(upperAscii(s.layer));
        shapes.push_back(std::move(s));
    }

    LoadContext& ctx_;
    std::string path_;
    double tol_;
    int groups_ = 0;
    Info current_, pending_;
    std::string section_;
    bool sectionNext_ = false, afterEof_ = false, ignore_ = false;
    std::optional<Shape> poly_;
    bool polyMirror_ = false;
    std::vector<Vertex> vertices_;
};

/// The scale that $INSUNITS asks for (metres per drawing unit), nullopt when unknown or unitless.
std::optional<std::pair<double, const char*>> unitsScale(int insunits) {
    switch (insunits) {
        case 1: return std::make_pair(0.0254, "inches");
        case 2: return std::make_pair(0.3048, "feet");
        case 4: return std::make_pair(0.001, "millimetres");
        case 5: return std::make_pair(0.01, "centimetres");
        case 6: return std::make_pair(1.0, "metres");
        case 14: return std::make_pair(0.1, "decimetres");
        default: return std::nullopt;
    }
}

/// Puts the process's C locale back as it was when it was made.
class KeepLocale {
public:
    KeepLocale() {
        const char* c = std::setlocale(LC_ALL, nullptr);
        if (c != nullptr) c_ = c;
    }
    ~KeepLocale() {
        if (!c_.empty()) std::setlocale(LC_ALL, c_.c_str());
    }
    KeepLocale(const KeepLocale&) = delete;
    KeepLocale& operator=(const KeepLocale&) = delete;

private:
    std::string c_;  ///< the C locale's name, possibly composite ("LC_CTYPE=…;LC_NUMERIC=…")
};

void readDxf(LoadContext& ctx, const SourceLoc& namedBy, const std::string& path, double scale,
             std::vector<LayerRule>& rules) {
    std::string content;
    {
        std::ifstream in(path, std::ios::binary);
        if (!in) {
            ctx.diags.error(namedBy, "cannot read file '" + path + "'");
            return;
        }
        ctx.spec.includedFiles.push_back(path);
        std::ostringstream buf;
        buf << in.rdbuf();
        content = buf.str();
    }
    DxfScan scan;
    if (!scanDxf(ctx, path, content, scan)) return;

    if (scan.insunits) {
        if (const auto units = unitsScale(*scan.insunits); units && std::abs(units->first - scale) > 1e-9 * units->first)
            ctx.diags.warning(SourceLoc{path, 0}, "the drawing's $INSUNITS (" + std::to_string(*scan.insunits) + ") says " +
                                                      units->second + ", which is scale=\"" + formatNumber(units->first) +
                                                      "\", but scale=\"" + formatNumber(scale) + "\" is used (" +
                                                      namedBy.file + ":" + std::to_string(namedBy.line) + ")");
    }
    // Entities not read, by type (those on an ignored layer are not worth a word).
    std::map<std::string, std::pair<int, int>> unread;  // type → (count, line of the first)
    for (const DxfScan::Unread& u : scan.unsupported) {
        const bool ignored = std::any_of(rules.begin(), rules.end(), [&](const LayerRule& r) {
            return r.role == Role::Ignore && equalsIgnoreCase(r.name, u.layer);
        });
        if (ignored) continue;
        auto [it, fresh] = unread.emplace(u.type, std::make_pair(0, u.line));
        ++it->second.first;
    }
    for (const auto& [type, seen] : unread) {
        const int count = seen.first;
        ctx.diags.warning(SourceLoc{path, seen.second},
                          std::to_string(count) + " " + type + " entit" + (count == 1 ? "y" : "ies") +
                              " ignored (CrowdHealth reads LINE, LWPOLYLINE, POLYLINE, ARC and CIRCLE" +
                              (type == "INSERT" ? "; explode block references in the CAD program" : "") +
                              "; map their layer as=\"ignore\" to silence this)");
    }

    DxfCollector collector(ctx, path, kChordError / scale);
    DL_Dxf dxf;
    bool ok = false;
    try {
        // dxflib sets the C++ global locale to "C" while reading and then back to what it was,
        // which also sets the C locale to that locale's name. In a program whose C locale is not
        // its C++ global locale's (Python: C.UTF-8 against "C"), the C locale was left "C" (Python
        // then read text files as ASCII). It is put back as it was. One drawing at a time: the
        // locale is the process's, and a sweep's runs load their scenarios on several threads.
        static std::mutex oneAtATime;
        const std::lock_guard<std::mutex> lock(oneAtATime);
        const KeepLocale keep;
        ok = dxf.in(path, &collector);
        collector.finish();
    } catch (const std::exception& e) {
        ctx.diags.error(SourceLoc{path, 0}, std::string("dxflib could not read the drawing: ") + e.what());
        return;
    }
    if (!ok) {
        ctx.diags.error(namedBy, "cannot read file '" + path + "'");
        return;
    }

    for (LayerRule& rule : rules) {
        rule.seen = scan.layers.count(upperAscii(rule.name)) != 0;
        if (!rule.seen) {
            std::vector<std::string> known;
            for (const auto& [up, spelt] : scan.layerSpelling) known.push_back(spelt);
            std::string list;
            for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
            const std::string near = closestMatch(rule.name, known);
            ctx.diags.warning(rule.loc, "Layer '" + rule.name + "': no entity of " + path + " is on this layer" +
                                            (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                                            "; layers with entities: " + (list.empty() ? "none" : list));
        }
    }
    const int errorsBefore = ctx.diags.errorCount();
    ShapeSink sink(ctx, path);
    for (Shape& s : collector.shapes) {
        for (Vec2& p : s.pts) p *= scale;
        LayerRule* rule = nullptr;
        for (LayerRule& r : rules)
            if (equalsIgnoreCase(r.name, s.layer)) rule = &r;
        sink.add(std::move(s), rule != nullptr ? rule->role : Role::Wall, rule);
    }
    if (sink.used() == 0 && ctx.diags.errorCount() == errorsBefore)
        ctx.diags.error(namedBy, "Obstacles@file: '" + path + "' holds no usable entity (a LINE, LWPOLYLINE, POLYLINE, "
                                 "ARC or CIRCLE in the model space, on a layer not ignored)");
}

// ---------------------------------------------------------------------------------------------
// WKT

struct WktError {
    std::size_t pos;
    std::string message;
};

struct WktRing {
    std::vector<Vec2> pts;
    std::size_t pos = 0;  ///< offset of its '('
};

/// POLYGON and MULTIPOLYGON in well-known text, strictly (docs/geometry.md gives the grammar).
class WktParser {
public:
    explicit WktParser(const std::string& text) : t_(text) {}

    std::vector<std::vector<WktRing>> parse() {
        std::vector<std::vector<WktRing>> polygons;
        skip();
        const std::size_t at = pos_;
        const std::string kw = upperAscii(word());
        if (kw == "POLYGON") {
            dimensions();
            polygons.push_back(polygonText());
        } else if (kw == "MULTIPOLYGON") {
            dimensions();
            expect('(', "'(' opening the MULTIPOLYGON's list of polygons");
            do polygons.push_back(polygonText());
            while (accept(','));
            expect(')', "',' or ')' after a polygon");
        } else {
            throw WktError{at, kw.empty() ? "expected POLYGON or MULTIPOLYGON, found " + found()
                                          : "expected POLYGON or MULTIPOLYGON, found '" + shortText(kw) +
                                                "' (a .wkt venue is the walkable area: one POLYGON or MULTIPOLYGON)"};
        }
        skip();
        if (pos_ < t_.size())
            throw WktError{pos_, "unexpected " + found() + " after the geometry: a .wkt file holds one POLYGON or MULTIPOLYGON"};
        return polygons;
    }

    /// 1-based line and column of an offset.
    std::pair<int, int> lineColumn(std::size_t pos) const {
        int line = 1, col = 1;
        for (std::size_t i = 0; i < pos && i < t_.size(); ++i) {
            if (t_[i] == '\n') {
                ++line;
                col = 1;
            } else {
                ++col;
            }
        }
        return {line, col};
    }

private:
    void skip() {
        while (pos_ < t_.size() && (t_[pos_] == ' ' || t_[pos_] == '\t' || t_[pos_] == '\r' || t_[pos_] == '\n')) ++pos_;
    }
    std::string found() const {
        if (pos_ >= t_.size()) return "the end of the file";
        std::size_t e = pos_;
        if (std::isalnum(static_cast<unsigned char>(t_[e])) || t_[e] == '-' || t_[e] == '+' || t_[e] == '.')
            while (e < t_.size() && (std::isalnum(static_cast<unsigned char>(t_[e])) || t_[e] == '-' || t_[e] == '+' || t_[e] == '.')) ++e;
        else
            ++e;
        return "'" + shortText(t_.substr(pos_, e - pos_)) + "'";
    }
    std::string word() {
        skip();
        const std::size_t b = pos_;
        while (pos_ < t_.size() && std::isalpha(static_cast<unsigned char>(t_[pos_]))) ++pos_;
        return t_.substr(b, pos_ - b);
    }
    bool accept(char c) {
        skip();
        if (pos_ < t_.size() && t_[pos_] == c) {
            ++pos_;
            return true;
        }
        return false;
    }
    void expect(char c, const std::string& what) {
        if (!accept(c)) throw WktError{pos_, "expected " + what + ", found " + found()};
    }
    /// Rejects Z, M, ZM and EMPTY after the keyword.
    void dimensions() {
        skip();
        const std::size_t at = pos_;
        const std::string w = upperAscii(word());
        if (w == "EMPTY") throw WktError{at, "an EMPTY geometry gives no walls"};
        if (w == "Z" || w == "M" || w == "ZM") throw WktError{at, "only 2-D coordinates (x y) are supported, not " + w};
        if (!w.empty()) throw WktError{at, "expected '(', found '" + shortText(w) + "'"};
    }
    std::vector<WktRing> polygonText() {
        skip();
        if (pos_ < t_.size() && std::isalpha(static_cast<unsigned char>(t_[pos_]))) dimensions();
        expect('(', "'(' opening a polygon");
        std::vector<WktRing> rings;
        do rings.push_back(ring());
        while (accept(','));
        expect(')', "',' or ')' after a ring");
        return rings;
    }
    WktRing ring() {
        skip();
        WktRing r;
        r.pos = pos_;
        expect('(', "'(' opening a ring");
        do {
            const double x = number("x");
            const double y = number("y");
            skip();
            if (pos_ < t_.size() && (std::isdigit(static_cast<unsigned char>(t_[pos_])) || t_[pos_] == '-' || t_[pos_] == '+' || t_[pos_] == '.'))
                throw WktError{pos_, "a third coordinate: only 2-D points (x y) are supported"};
            r.pts.emplace_back(x, y);
        } while (accept(','));
        expect(')', "',' or ')' after a point");
        return r;
    }
    double number(const char* what) {
        skip();
        const std::size_t b = pos_;
        while (pos_ < t_.size() && (std::isalnum(static_cast<unsigned char>(t_[pos_])) || t_[pos_] == '-' || t_[pos_] == '+' || t_[pos_] == '.'))
            ++pos_;
        const std::string tok = t_.substr(b, pos_ - b);
        double v = 0;
        bool digits = false;
        for (char c : tok) digits = digits || std::isdigit(static_cast<unsigned char>(c));
        if (tok.empty() || !digits || !parseReal(tok, v)) {
            pos_ = b;
            throw WktError{b, std::string("expected a number (") + what + "), found " + found()};
        }
        return v;
    }

    const std::string& t_;
    std::size_t pos_ = 0;
};

void readWkt(LoadContext& ctx, const SourceLoc& namedBy, const std::string& path, double scale) {
    std::string text;
    {
        std::ifstream in(path, std::ios::binary);
        if (!in) {
            ctx.diags.error(namedBy, "cannot read file '" + path + "'");
            return;
        }
        ctx.spec.includedFiles.push_back(path);
        std::ostringstream buf;
        buf << in.rdbuf();
        text = buf.str();
    }
    // A UTF-8 byte-order mark (some Windows editors write one) is not part of the text; blank it
    // so that columns still count from the file's first byte.
    if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.replace(0, 3, "   ");
    WktParser parser(text);
    const auto at = [&](std::size_t pos) {
        const auto [line, col] = parser.lineColumn(pos);
        return std::make_pair(SourceLoc{path, line}, "column " + std::to_string(col) + ": ");
    };
    std::vector<std::vector<WktRing>> polygons;
    try {
        polygons = parser.parse();
    } catch (const WktError& e) {
        const auto [loc, col] = at(e.pos);
        ctx.diags.error(loc, col + e.message);
        return;
    }
    const int errorsBefore = ctx.diags.errorCount();
    // Check every ring first: closed, three distinct corners, an area; holes inside their outer ring.
    for (std::size_t p = 0; p < polygons.size(); ++p) {
        for (std::size_t k = 0; k < polygons[p].size(); ++k) {
            WktRing& r = polygons[p][k];
            const auto [loc, col] = at(r.pos);
            const std::string which = (k == 0 ? std::string("outer ring") : "hole " + std::to_string(k)) +
                                      (polygons.size() > 1 ? " of polygon " + std::to_string(p + 1) : "");
            if (r.pts.size() < 4) {
                ctx.diags.error(loc, col + which + " has " + std::to_string(r.pts.size()) +
                                         " points: a ring needs at least 4 (three corners, then the first again)");
                continue;
            }
            if ((r.pts.front() - r.pts.back()).norm() > 0) {
                ctx.diags.error(loc, col + which + " is not closed: a WKT ring repeats its first point at its end (" +
                                         std::to_string(r.pts.size()) + " points)");
                continue;
            }
            r.pts.pop_back();
            dropRepeats(r.pts, true);
            if (r.pts.size() < 3 || !(std::abs(polygonArea(r.pts)) > 0)) {
                ctx.diags.error(loc, col + which + " has no area");
                continue;
            }
            if (k > 0 && polygons[p][0].pts.size() >= 3)
                for (const Vec2& v : r.pts)
                    if (!pointInPolygon(v, polygons[p][0].pts)) {
                        ctx.diags.error(loc, col + which + " has a corner (" + formatNumber(v.x()) + ", " +
                                                 formatNumber(v.y()) + ") outside its outer ring");
                        break;
                    }
        }
    }
    if (ctx.diags.errorCount() > errorsBefore) return;
    ShapeSink sink(ctx, path);
    for (auto& rings : polygons)
        for (std::size_t k = 0; k < rings.size(); ++k) {
            Shape s;
            s.pts = rings[k].pts;
            for (Vec2& v : s.pts) v *= scale;
            s.closed = true;
            s.type = k == 0 ? "POLYGON outer ring" : "POLYGON hole";
            s.loc = at(rings[k].pos).first;
            // The outer ring bounds the walkable area: agents are inside, so it is walls only.
            // A hole is not walkable: a solid obstacle.
            sink.add(std::move(s), k == 0 ? Role::Boundary : Role::Wall, nullptr);
        }
}

}  // namespace

bool isGeometryFile(const std::string& name) {
    const std::string ext = upperAscii(std::filesystem::path(name).extension().string());
    return ext == ".DXF" || ext == ".WKT";
}

void readGeometryFile(LoadContext& ctx, const std::string& file, const XMLElement* el, ElementReader& r,
                      const std::string& name) {
    namespace fs = std::filesystem;
    const SourceLoc namedBy = r.loc("file");
    const bool dxf = upperAscii(fs::path(name).extension().string()) == ".DXF";
    const double scale = r.value("scale");

    std::vector<LayerRule> rules;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (!dxf) {
            reportUnexpectedElement(ctx, file, c, el->Name(), {});
            continue;
        }
        if (!is(c, "Layer")) {
            reportUnexpectedElement(ctx, file, c, el->Name(), {"Layer"});
            continue;
        }
        ElementReader lr(ctx, file, c, "Layer", layerTable(), {"name", "prefix"});
        for (const XMLElement* g = c->FirstChildElement(); g != nullptr; g = g->NextSiblingElement())
            reportUnexpectedElement(ctx, file, g, c->Name(), {});
        LayerRule rule;
        rule.loc = lr.loc();
        rule.name = lr.text("name").value_or("");
        if (rule.name.empty()) {
            lr.error(lr.loc(), "Layer: missing required attribute name (a layer of the drawing)");
            continue;
        }
        if (!lr.has("as")) {
            lr.error(lr.loc(), "Layer@as: missing required value (one of: wall, boundary, exit, target, line, area, ignore)");
            continue;
        }
        rule.role = static_cast<Role>(static_cast<int>(lr.value("as")));
        rule.prefix = lr.text("prefix").value_or(idSafe(rule.name));
        if (rule.prefix.empty() || rule.prefix.find_first_of(" \t\r\n,\"") != std::string::npos) {
            lr.error(lr.loc("prefix"), "Layer@prefix: '" + rule.prefix + "' must be non-empty, without spaces, commas or quotes");
            continue;
        }
        if (lr.has("prefix") && (rule.role == Role::Wall || rule.role == Role::Boundary || rule.role == Role::Ignore))
            ctx.diags.warning(lr.loc("prefix"), "Layer@prefix names exits, targets, lines and areas; a " +
                                                    roleWords()[static_cast<std::size_t>(rule.role)] + " layer has no names");
        bool duplicate = false;
        for (const LayerRule& other : rules)
            if (equalsIgnoreCase(other.name, rule.name)) {
                lr.error(lr.loc("name"), "Layer '" + rule.name + "' is mapped twice (first at line " +
                                             std::to_string(other.loc.line) + ")");
                duplicate = true;
            }
        if (!lr.failed() && !duplicate) rules.push_back(rule);
    }
    if (r.failed()) return;

    const std::string path = (fs::path(file).parent_path() / fs::path(name)).string();
    std::error_code ec;
    if (!fs::exists(path, ec)) {
        ctx.diags.error(namedBy, "cannot find file '" + name + "'" + (name != path ? " (looked for '" + path + "')" : ""));
        return;
    }
    if (fs::is_directory(path, ec)) {
        ctx.diags.error(namedBy, "file '" + name + "' is a directory, not a " + (dxf ? "DXF" : "WKT") + " file");
        return;
    }
    if (dxf) readDxf(ctx, namedBy, path, scale, rules);
    else readWkt(ctx, namedBy, path, scale);
}

}  // namespace ch::xmlio
