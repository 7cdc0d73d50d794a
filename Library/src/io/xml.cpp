// CrowdHealth — XML loader: documents and files, <Simulation>, <World>, <Output>, and the checks
// that need the whole scenario (agent ids, policy references). See xml_internal.h for the layout.
#include "crowdhealth/io/xml.h"

#include "crowdhealth/core/plugins.h"

#include "xml_internal.h"

#include "crowdhealth/io/output.h"
#include "crowdhealth/health/safety.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string_view>
#include <unistd.h>

namespace ch {

namespace xmlio {

namespace {

/// Elements that may stand at the top of a file. A file named by `file=` may hold several (UMANS'
/// own agents/1to10-*.xml start with a stray <Simulation/>); only the expected one is read.
const std::vector<std::string> kRootNames = {"Simulation", "Agents", "Policies", "Obstacles"};

/// Where each known element belongs, for "<Agent> belongs inside <Agents>" hints.
const std::map<std::string, std::string>& homes() {
    static const std::map<std::string, std::string> m = {
        {"simulation", "the top of the scenario file"},
        {"world", "<Simulation>"},
        {"output", "<Simulation>"},
        {"policies", "<Simulation>"},
        {"agents", "<Simulation>"},
        {"obstacles", "<World>"},
        {"policy", "<Policies> (or, with an id only, inside an <Agent>)"},
        {"step", "<Policy>"},
        {"costfunction", "<Policy> or <Step>"},
        {"agent", "<Agents>"},
        {"agentgrid", "<Agents>"},
        {"spawnrectangle", "<Agents>"},
        {"pos", "<Agent>"},
        {"goal", "<Agent>, <AgentGrid> or <SpawnRectangle>"},
        {"color", "<Agent>"},
        {"obstacle", "<Obstacles> or <World>"},
        {"box", "<Obstacles> or <World>"},
        {"point", "<Obstacle>"},
        {"layer", "<Obstacles file=\"….dxf\">"},
        {"schedule", "<Simulation>"},
        {"ramp", "<Schedule>"},
        {"panicevent", "<Schedule>"},
        {"crowdhealth", "<Policy>"},
        {"navigation", "<World>"},
        {"target", "<World>"},
        {"exit", "<World>"},
        {"exitset", "<World>"},
        {"journey", "<World>"},
        {"waypoint", "<Journey>"},
        {"source", "<Agents>"},
        {"rate", "<Source>"},
        {"draw", "<Source>"},
        {"closeexit", "<Schedule>"},
        {"openexit", "<Schedule>"},
        {"measurement", "<Simulation>"},
        {"line", "<Measurement>"},
        {"area", "<Measurement>"},
    };
    return m;
}

std::string lowerAscii(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

bool isBlank(const char* s) {
    for (; s != nullptr && *s != '\0'; ++s)
        if (!std::isspace(static_cast<unsigned char>(*s))) return false;
    return true;
}

std::string joined(const std::vector<std::string>& words) {
    std::string out;
    for (std::size_t i = 0; i < words.size(); ++i) out += (i ? ", " : "") + words[i];
    return out;
}

}  // namespace

bool is(const XMLElement* el, const char* name) { return equalsIgnoreCase(el->Name(), name); }

SourceLoc locOf(const std::string& file, const XMLElement* el) { return SourceLoc{file, el->GetLineNum()}; }

bool reportIfUnsupported(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    // Every planned extension of DESIGN §3/§5 is implemented now (<Schedule>, <CrowdHealth>).
    (void)ctx;
    (void)file;
    (void)el;
    return false;
}

void reportUnexpectedElement(LoadContext& ctx, const std::string& file, const XMLElement* child,
                             const std::string& parent, const std::vector<std::string>& allowed) {
    if (reportIfUnsupported(ctx, file, child)) return;
    const std::string name = child->Name();
    const std::string where = parent.empty() ? "at the top level" : "in <" + parent + ">";
    std::string msg = "unknown element <" + name + "> " + where;
    const std::string hint = closestMatch(name, allowed);
    if (!hint.empty()) {
        msg += " (did you mean '" + hint + "'?)";
    } else {
        auto home = homes().find(lowerAscii(name));
        if (home != homes().end())
            msg = "<" + name + "> is not allowed " + where + "; it belongs inside " + home->second;
        else if (allowed.empty())
            msg = "unexpected element <" + name + "> " + where + " (<" + parent + "> takes no child elements)";
        else
            msg += "; allowed here: " + joined(allowed);
    }
    ctx.diags.error(locOf(file, child), msg);
}

// ---------------------------------------------------------------------------------------------
// ElementReader

ElementReader::ElementReader(LoadContext& ctx, std::string file, const XMLElement* el, std::string display,
                             const ParamTable& table, std::vector<std::string> extras)
    : ctx_(ctx), file_(std::move(file)), el_(el), display_(std::move(display)), table_(table) {
    // Attribute names are case-sensitive, as in UMANS (which silently ignores a misspelt one);
    // we report it, and a case-only difference gets its exact spelling as the suggestion. (The
    // list of allowed names is made only for a message: this runs for every element of a file,
    // four times per agent of a UMANS scenario.)
    auto known = [&](const char* name) {
        for (const ParamSpec& p : table_)
            if (p.name == name) return true;
        return std::find(extras.begin(), extras.end(), name) != extras.end();
    };
    for (const tinyxml2::XMLAttribute* a = el_->FirstAttribute(); a != nullptr; a = a->Next()) {
        if (known(a->Name())) continue;
        std::vector<std::string> names;
        for (const ParamSpec& p : table_) names.push_back(p.name);
        names.insert(names.end(), extras.begin(), extras.end());
        std::string msg = "unknown attribute '" + std::string(a->Name()) + "' on <" + el_->Name() + ">";
        const std::string hint = closestMatch(a->Name(), names);
        if (!hint.empty())
            msg += " (did you mean '" + hint + "'?)";
        else if (names.empty())
            msg += " (it takes no attributes)";
        else
            msg += "; allowed: " + joined(names);
        error(SourceLoc{file_, a->GetLineNum()}, msg);
    }
    for (const tinyxml2::XMLNode* n = el_->FirstChild(); n != nullptr; n = n->NextSibling()) {
        const tinyxml2::XMLText* t = n->ToText();
        if (t != nullptr && !isBlank(t->Value())) {
            std::string shown = t->Value();
            if (shown.size() > 40) shown = shown.substr(0, 37) + "...";
            error(SourceLoc{file_, n->GetLineNum()},
                  "unexpected text '" + shown + "' in <" + std::string(el_->Name()) + ">");
        }
    }
}

SourceLoc ElementReader::loc(const std::string& attr) const {
    for (const tinyxml2::XMLAttribute* a = el_->FirstAttribute(); a != nullptr; a = a->Next())
        if (attr == a->Name()) return SourceLoc{file_, a->GetLineNum()};
    return loc();
}

std::optional<std::string> ElementReader::text(const std::string& attr) const {
    const char* v = el_->Attribute(attr.c_str());
    if (v == nullptr) return std::nullopt;
    return std::string(v);
}

const ParamSpec& ElementReader::spec(const std::string& attr) const {
    for (const ParamSpec& p : table_)
        if (p.name == attr) return p;
    throw std::logic_error("XML loader: <" + display_ + "> has no table entry '" + attr + "'");
}

std::optional<double> ElementReader::optional(const std::string& attr) {
    const ParamSpec& p = spec(attr);
    const char* raw = el_->Attribute(attr.c_str());
    if (raw == nullptr) return std::nullopt;
    double v = 0;
    std::string why;
    if (!p.parse(raw, v, why)) {
        error(loc(attr), display_ + "@" + attr + ": " + why);
        return std::nullopt;
    }
    // Unbounded whole numbers (counts, ids) end up in an int.
    if (p.type == ParamType::Integer && p.max >= 1e300 && std::fabs(v) > 2147483647.0) {
        error(loc(attr), display_ + "@" + attr + ": " + raw + " is too large (at most 2147483647)");
        return std::nullopt;
    }
    return v;
}

std::optional<double> ElementReader::required(const std::string& attr) {
    if (!has(attr)) {
        const ParamSpec& p = spec(attr);
        std::string expected = p.rangeText();
        error(loc(), display_ + "@" + attr + ": missing required value (" +
                         (p.type == ParamType::Choice ? expected : "expected in " + expected) + ")");
        return std::nullopt;
    }
    return optional(attr);
}

double ElementReader::value(const std::string& attr) {
    std::optional<double> v = optional(attr);
    return v ? *v : spec(attr).defaultValue;
}

void ElementReader::error(const SourceLoc& where, const std::string& message) {
    failed_ = true;
    ctx_.diags.error(where, message);
}

// ---------------------------------------------------------------------------------------------
// Shared small elements

std::optional<Vec2> readPoint(LoadContext& ctx, const std::string& file, const XMLElement* el,
                              const std::string& display) {
    static const ParamTable table = {
        ParamSpec::real("x", "m", 0, -1e300, 1e300, "x coordinate"),
        ParamSpec::real("y", "m", 0, -1e300, 1e300, "y coordinate"),
    };
    ElementReader r(ctx, file, el, display, table);
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    const std::optional<double> x = r.required("x");
    const std::optional<double> y = r.required("y");
    if (!x || !y) return std::nullopt;
    return Vec2(*x, *y);
}

std::optional<int> readPolicyRef(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    static const ParamTable table = {
        ParamSpec::integer("id", 0, 0, 1e300, "id of a <Policy> in <Policies>"),
    };
    ElementReader r(ctx, file, el, "Policy", table);
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    const std::optional<double> id = r.required("id");
    if (!id) return std::nullopt;
    ctx.policyRefs.push_back({static_cast<int>(*id), r.loc("id")});
    return static_cast<int>(*id);
}

void reserveAgents(LoadContext& ctx, std::size_t more) {
    const std::size_t need = ctx.spec.agents.size() + more;
    if (need <= ctx.spec.agents.capacity()) return;
    const std::size_t room = std::max(need, 2 * ctx.spec.agents.capacity());
    ctx.spec.agents.reserve(room);
    ctx.agentOrigins.reserve(room);
}

void addAgent(LoadContext& ctx, AgentSpec agent, bool explicitId, const SourceLoc& idLoc) {
    ctx.spec.agents.push_back(std::move(agent));
    ctx.agentOrigins.push_back({explicitId, idLoc});
}

namespace {

// ---------------------------------------------------------------------------------------------
// Documents and blocks

enum class Block { Policies, Agents, Obstacles };

const char* blockName(Block b) {
    switch (b) {
        case Block::Policies: return "Policies";
        case Block::Agents: return "Agents";
        case Block::Obstacles: return "Obstacles";
    }
    return "";
}

std::vector<std::string> blockChildren(Block b) {
    switch (b) {
        case Block::Policies: return {"Policy", "Plugin"};
        case Block::Agents: return {"Agent", "AgentGrid", "SpawnRectangle", "Source"};
        case Block::Obstacles: return {"Obstacle", "Box"};
    }
    return {};
}

/// Turns "XML_ERROR_MISMATCHED_ELEMENT" into "mismatched element".
std::string friendlyErrorName(const char* name) {
    std::string s = name != nullptr ? name : "unknown error";
    if (s.rfind("XML_ERROR_", 0) == 0) s = s.substr(10);
    else if (s.rfind("XML_", 0) == 0) s = s.substr(4);
    s = lowerAscii(s);
    std::replace(s.begin(), s.end(), '_', ' ');
    return s;
}

/// Why the file at `path` cannot be XML text, judged from its first bytes: empty, UTF-16/32 (which
/// tinyxml2 would misread as garbage), or binary (NUL bytes or many control characters). nullopt
/// when it looks like text (or cannot be read: the parser reports that).
std::optional<std::string> notXmlText(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return std::nullopt;
    std::string head(64 * 1024, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
    const auto starts = [&](std::string_view bom) { return head.compare(0, bom.size(), bom) == 0; };
    if (head.empty()) return "the file is empty";
    if (starts(std::string_view("\xFF\xFE\x00\x00", 4)) || starts(std::string_view("\x00\x00\xFE\xFF", 4)))
        return "UTF-32 is not supported: save it as UTF-8";
    if (starts("\xFF\xFE") || starts("\xFE\xFF")) return "UTF-16 is not supported: save it as UTF-8";
    // UTF-16 without a byte-order mark: ASCII characters with a zero byte beside each.
    if (head.size() >= 4 && ((head[0] == '<' && head[1] == '\0' && head[3] == '\0') ||
                             (head[0] == '\0' && head[1] == '<' && head[2] == '\0')))
        return "UTF-16 is not supported: save it as UTF-8";
    std::size_t control = 0;
    bool blank = true;
    for (const char ch : head) {
        const auto c = static_cast<unsigned char>(ch);
        if (c == 0) return "not a text file (it holds NUL bytes): a scenario must be an XML text file";
        if (c < 0x20 && c != '\t' && c != '\n' && c != '\r' && c != '\f') ++control;
        if (c != ' ' && c != '\t' && c != '\n' && c != '\r') blank = false;
    }
    if (control * 20 > head.size())
        return "not a text file (it holds control characters): a scenario must be an XML text file";
    if (blank && !in) return "the file is empty (it holds only white space)";
    return std::nullopt;
}

/// The syntax error tinyxml2 found in `doc` (read from `path`) as a diagnostic at its line;
/// returns false (for the callers' `return`).
bool reportSyntaxError(LoadContext& ctx, const std::string& path, const tinyxml2::XMLDocument& doc) {
    // tinyxml2's ErrorStr() is "Error=NAME ErrorID=N (0xN) Line number=L[: detail]"; keep the detail.
    std::string detail = doc.ErrorStr() != nullptr ? doc.ErrorStr() : "";
    const auto lineTag = detail.find("Line number=");
    const auto colon = lineTag == std::string::npos ? std::string::npos : detail.find(": ", lineTag);
    detail = colon == std::string::npos ? "" : detail.substr(colon + 2);
    std::string msg = "XML syntax error: " + friendlyErrorName(doc.ErrorName());
    if (!detail.empty()) msg += " (" + detail + ")";
    ctx.diags.error(SourceLoc{path, doc.ErrorLineNum()}, msg);
    return false;
}

/// Loads and parses `path`. Reports a missing file at `namedBy` (the element whose file= names
/// it) when given, and a syntax error at the line tinyxml2 stopped on.
bool loadDocument(LoadContext& ctx, const std::string& path, const SourceLoc* namedBy,
                  const std::string& asWritten, tinyxml2::XMLDocument& doc) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const SourceLoc where = namedBy != nullptr ? *namedBy : SourceLoc{path, 0};
    const std::string what = namedBy != nullptr && asWritten != path
                                 ? "file '" + asWritten + "' (looked for '" + path + "')"
                                 : "file '" + path + "'";
    if (!fs::exists(path, ec)) {
        ctx.diags.error(where, "cannot find " + what);
        return false;
    }
    if (fs::is_directory(path, ec)) {
        ctx.diags.error(where, what + " is a directory, not an XML file");
        return false;
    }
    if (const std::optional<std::string> problem = notXmlText(path)) {
        std::string msg = *problem;
        if (namedBy != nullptr) msg += " (named at " + namedBy->file + ":" + std::to_string(namedBy->line) + ")";
        ctx.diags.error(SourceLoc{path, 1}, msg);
        return false;
    }
    const tinyxml2::XMLError err = doc.LoadFile(path.c_str());
    if (err == tinyxml2::XML_SUCCESS) {
        if (namedBy != nullptr) ctx.spec.includedFiles.push_back(path);
        return true;
    }
    if (err == tinyxml2::XML_ERROR_EMPTY_DOCUMENT) {
        ctx.diags.error(SourceLoc{path, 1}, "the file holds no XML element");
        return false;
    }
    if (err == tinyxml2::XML_ERROR_FILE_NOT_FOUND || err == tinyxml2::XML_ERROR_FILE_COULD_NOT_BE_OPENED ||
        err == tinyxml2::XML_ERROR_FILE_READ_ERROR) {
        ctx.diags.error(where, "cannot read " + what);
        return false;
    }
    return reportSyntaxError(ctx, path, doc);
}

/// Parses `text` as the content of `path` (LoadOptions::text), with loadDocument's messages.
bool parseDocumentText(LoadContext& ctx, const std::string& path, const std::string& text, tinyxml2::XMLDocument& doc) {
    const tinyxml2::XMLError err = doc.Parse(text.data(), text.size());
    if (err == tinyxml2::XML_SUCCESS) return true;
    if (err == tinyxml2::XML_ERROR_EMPTY_DOCUMENT) {
        ctx.diags.error(SourceLoc{path, 1}, "the file holds no XML element");
        return false;
    }
    return reportSyntaxError(ctx, path, doc);
}

void readBlock(LoadContext& ctx, const std::string& file, const XMLElement* el, Block kind, bool external);

/// `<Agents file="…"/>` and friends: reads the expected root element(s) of the named file.
void readExternalBlock(LoadContext& ctx, const std::string& file, const XMLElement* el, Block kind,
                       const std::string& name) {
    namespace fs = std::filesystem;
    const SourceLoc namedBy{file, el->GetLineNum()};
    // Relative to the directory of the file that names it (UMANS resolves them the same way).
    const std::string path = (fs::path(file).parent_path() / fs::path(name)).string();
    std::error_code same;
    if (fs::equivalent(path, file, same)) {
        ctx.diags.error(namedBy, std::string(blockName(kind)) + "@file: '" + name +
                                     "' is this file itself: a file cannot include itself");
        if (kind == Block::Policies) ctx.policiesIncomplete = true;
        if (kind == Block::Agents) ctx.agentsIncomplete = true;
        return;
    }
    tinyxml2::XMLDocument doc;
    if (!loadDocument(ctx, path, &namedBy, name, doc)) {
        if (kind == Block::Policies) ctx.policiesIncomplete = true;
        if (kind == Block::Agents) ctx.agentsIncomplete = true;
        return;
    }
    bool found = false;
    for (const XMLElement* top = doc.FirstChildElement(); top != nullptr; top = top->NextSiblingElement()) {
        if (is(top, blockName(kind))) {
            found = true;
            readBlock(ctx, path, top, kind, true);
            continue;
        }
        const bool knownRoot = std::any_of(kRootNames.begin(), kRootNames.end(),
                                           [&](const std::string& r) { return is(top, r.c_str()); });
        if (!knownRoot) reportUnexpectedElement(ctx, path, top, "", {blockName(kind)});
    }
    if (!found) {
        ctx.diags.error(namedBy, "file '" + name + "' has no <" + blockName(kind) + "> element");
        if (kind == Block::Policies) ctx.policiesIncomplete = true;
        if (kind == Block::Agents) ctx.agentsIncomplete = true;
    }
}

const ParamTable& obstaclesTable() {
    static const ParamTable t = [] {
        ParamTable table = {
            ParamSpec::real("scale", "-", 1.0, 0, 1e300,
                            "file=*.dxf|*.wkt: metres per drawing unit (0.001 for millimetres)"),
        };
        table[0].minExclusive = true;
        return table;
    }();
    return t;
}

/// `<Plugin file="…"/>`: loads the plugin (relative to the file that names it) before the
/// policies that use its components are read. Every <Plugin> child of `el` is loaded here, first,
/// wherever it stands among its siblings.
void readPlugins(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    namespace fs = std::filesystem;
    static const ParamTable none;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (!is(c, "Plugin")) continue;
        ElementReader r(ctx, file, c, "Plugin", none, {"file"});
        if (c->FirstChildElement() != nullptr)
            r.error(locOf(file, c->FirstChildElement()), "<Plugin> has no child elements; give only file=\"…\"");
        const std::optional<std::string> name = r.text("file");
        if (!name || name->empty()) {
            r.error(r.loc(), "<Plugin> needs file=\"…\": the plugin's shared library (.so), relative to this file");
            ctx.pluginFailed = true;
            continue;
        }
        const PluginLoad load = loadPlugin(findPlugin(*name, fs::path(file).parent_path().string()));
        if (!load.ok) {
            r.error(r.loc("file"), "Plugin@file: '" + *name + "' " + load.error);
            ctx.pluginFailed = true;
            continue;
        }
        if (std::find(ctx.spec.plugins.begin(), ctx.spec.plugins.end(), load.path) == ctx.spec.plugins.end())
            ctx.spec.plugins.push_back(load.path);
    }
}

void readBlock(LoadContext& ctx, const std::string& file, const XMLElement* el, Block kind, bool external) {
    static const ParamTable none;
    // A file named by file= cannot name another one: no chains, no cycles.
    ElementReader r(ctx, file, el, blockName(kind), kind == Block::Obstacles ? obstaclesTable() : none, {"file"});
    if (kind == Block::Obstacles && r.has("scale") && !isGeometryFile(r.text("file").value_or("")))
        r.error(r.loc("scale"), "Obstacles@scale applies to a DXF or WKT file (file=\"….dxf\" or \"….wkt\"); "
                                "XML obstacles are in metres");
    if (std::optional<std::string> name = r.text("file"); name && external) {
        namespace fs = std::filesystem;
        std::error_code same;
        const std::string path = (fs::path(file).parent_path() / fs::path(*name)).string();
        r.error(r.loc("file"), fs::equivalent(path, file, same)
                                   ? std::string(blockName(kind)) + "@file: '" + *name +
                                         "' is this file itself: a file cannot include itself"
                                   : std::string(blockName(kind)) + "@file: a file named by file= cannot name "
                                         "another file; put the <" + blockName(kind) + "> content here or name '" +
                                         *name + "' from the main scenario");
        if (kind == Block::Policies) ctx.policiesIncomplete = true;
        if (kind == Block::Agents) ctx.agentsIncomplete = true;
        return;
    } else if (name && kind == Block::Obstacles && isGeometryFile(*name)) {
        readGeometryFile(ctx, file, el, r, *name);
        return;
    } else if (name) {
        if (el->FirstChildElement() != nullptr)
            r.error(r.loc("file"), std::string("<") + el->Name() +
                                       " file=…> must not also contain elements; use one or the other");
        if (name->empty()) {
            r.error(r.loc("file"), std::string(blockName(kind)) + "@file: empty file name");
            return;
        }
        readExternalBlock(ctx, file, el, kind, *name);
        return;
    }
    const std::vector<std::string> allowed = blockChildren(kind);
    if (kind == Block::Policies) readPlugins(ctx, file, el);
    if (kind == Block::Agents) {
        // Room for every <Agent> at once (a 10,000-agent file would otherwise grow these arrays
        // a dozen times, copying the specs and touching fresh pages each time).
        std::size_t agents = 0;
        for (const XMLElement* c = el->FirstChildElement("Agent"); c != nullptr; c = c->NextSiblingElement("Agent"))
            ++agents;
        ctx.spec.agents.reserve(ctx.spec.agents.size() + agents);
        ctx.agentOrigins.reserve(ctx.agentOrigins.size() + agents);
        ctx.policyRefs.reserve(ctx.policyRefs.size() + agents);
    }
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        switch (kind) {
            case Block::Policies:
                if (is(c, "Policy")) { readPolicy(ctx, file, c); continue; }
                if (is(c, "Plugin")) continue;  // read first, by readPlugins
                break;
            case Block::Agents:
                if (is(c, "Agent")) { readAgent(ctx, file, c); continue; }
                if (is(c, "AgentGrid")) { readAgentGrid(ctx, file, c); continue; }
                if (is(c, "SpawnRectangle")) { readSpawnRectangle(ctx, file, c); continue; }
                if (is(c, "Source")) { readSource(ctx, file, c); continue; }
                break;
            case Block::Obstacles:
                if (is(c, "Obstacle")) { readObstacle(ctx, file, c); continue; }
                if (is(c, "Box")) { readBox(ctx, file, c); continue; }
                break;
        }
        reportUnexpectedElement(ctx, file, c, el->Name(), allowed);
    }
}

// ---------------------------------------------------------------------------------------------
// <Simulation>, <World>, <Output>

const ParamTable& worldTable() {
    static const ParamTable t = [] {
        ParamTable table = {
            ParamSpec::choice("type", {"Infinite", "Toric", "Planar"}, 0, "world topology"),
            ParamSpec::real("width", "m", 0, 0, 1e300, "Toric: period in x"),
            ParamSpec::real("height", "m", 0, 0, 1e300, "Toric: period in y"),
            ParamSpec::real("xmin", "m", 0, -1e300, 1e300, "Planar: lower x bound"),
            ParamSpec::real("xmax", "m", 0, -1e300, 1e300, "Planar: upper x bound"),
            ParamSpec::real("ymin", "m", 0, -1e300, 1e300, "Planar: lower y bound"),
            ParamSpec::real("ymax", "m", 0, -1e300, 1e300, "Planar: upper y bound"),
        };
        table[1].minExclusive = table[2].minExclusive = true;
        return table;
    }();
    return t;
}

const ParamTable& outputTable() {
    static const ParamTable t = [] {
        const OutputSpec d;
        ParamTable table = {
            ParamSpec::real("metrics_interval", "s", d.metricsInterval, 0, 1e300, "time between rows of metrics.csv"),
            // Absent: every coarse step (the default 0 stands for delta_time and is never parsed).
            ParamSpec::real("trajectory_interval", "s", d.trajectoryInterval, 0, 1e300,
                            "time between trajectory frames"),
            ParamSpec::boolean("trajectory_velocities", d.trajectoryVelocities,
                               "trajectories.bin records carry vx, vy too"),
            ParamSpec::integer("flow_first", d.flowFirst, 1, 1e300, "flow is measured from this evacuee"),
            ParamSpec::integer("flow_last", d.flowLast, 1, 1e300, "… to this evacuee"),
        };
        table[0].minExclusive = table[1].minExclusive = true;
        return table;
    }();
    return t;
}

void readWorld(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "World", worldTable());
    WorldSpec& w = ctx.spec.world;
    w.loc = r.loc();
    if (!r.has("type")) {
        // UMANS only warns here and falls back to an infinite world.
        ctx.diags.warning(r.loc(), "World@type is missing; using Infinite");
    }
    w.type = static_cast<WorldType>(static_cast<int>(r.value("type")));
    if (w.type == WorldType::Toric) {
        const auto width = r.required("width");
        const auto height = r.required("height");
        if (width) w.width = *width;
        if (height) w.height = *height;
    } else if (w.type == WorldType::Planar) {
        const auto xmin = r.required("xmin"), xmax = r.required("xmax");
        const auto ymin = r.required("ymin"), ymax = r.required("ymax");
        if (xmin && xmax) {
            if (*xmin >= *xmax) r.error(r.loc("xmax"), "World: xmin (" + *r.text("xmin") + ") must be less than xmax (" + *r.text("xmax") + ")");
            w.xmin = *xmin;
            w.xmax = *xmax;
        }
        if (ymin && ymax) {
            if (*ymin >= *ymax) r.error(r.loc("ymax"), "World: ymin (" + *r.text("ymin") + ") must be less than ymax (" + *r.text("ymax") + ")");
            w.ymin = *ymin;
            w.ymax = *ymax;
        }
    }
    // Attributes of another world type are not errors (UMANS ignores them) but are worth a word.
    const char* typeName = w.type == WorldType::Toric ? "Toric" : w.type == WorldType::Planar ? "Planar" : "Infinite";
    for (const char* attr : {"width", "height"})
        if (w.type != WorldType::Toric && r.has(attr))
            ctx.diags.warning(r.loc(attr), std::string("World@") + attr + " is ignored: it applies to Toric worlds, this one is " + typeName);
    for (const char* attr : {"xmin", "xmax", "ymin", "ymax"})
        if (w.type != WorldType::Planar && r.has(attr))
            ctx.diags.warning(r.loc(attr), std::string("World@") + attr + " is ignored: it applies to Planar worlds, this one is " + typeName);
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (is(c, "Obstacles")) readBlock(ctx, file, c, Block::Obstacles, false);
        else if (is(c, "Obstacle")) readObstacle(ctx, file, c);
        else if (is(c, "Box")) readBox(ctx, file, c);
        else if (is(c, "Navigation")) readNavigation(ctx, file, c);
        else if (is(c, "Target")) readTarget(ctx, file, c, false);
        else if (is(c, "Exit")) readTarget(ctx, file, c, true);
        else if (is(c, "ExitSet")) readExitSet(ctx, file, c);
        else if (is(c, "Journey")) readJourney(ctx, file, c);
        else reportUnexpectedElement(ctx, file, c, el->Name(),
                                     {"Obstacles", "Obstacle", "Box", "Navigation", "Target", "Exit", "ExitSet", "Journey"});
    }
}

/// The shortest text that reads back as v ("0.1", not "0.10000000000000001").
std::string shortestText(double v) {
    char buf[64];
    const auto res = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, res.ptr);
}

void readOutput(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    // trajectories is a word or a comma-separated list, which a ParamSpec choice cannot express:
    // it is read here, outside the table.
    ElementReader r(ctx, file, el, "Output", outputTable(), {"trajectories"});
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    OutputSpec& o = ctx.spec.output;
    o.loc = r.loc();
    o.metricsInterval = r.value("metrics_interval");
    if (const std::optional<std::string> t = r.text("trajectories")) {
        if (parseTrajectoryFormats(*t)) {
            o.trajectories = *t;
        } else {
            std::string message = "Output@trajectories: '" + *t + "' is not one of: " + kTrajectoryFormatWords +
                                  ", nor a comma-separated list of them such as txt,bin";
            const std::string hint = closestMatch(*t, {"umans", "txt", "bin", "both", "none"});
            if (!hint.empty()) message += " (did you mean '" + hint + "'?)";
            r.error(r.loc("trajectories"), message);
        }
    }
    if (const std::optional<double> interval = r.optional("trajectory_interval")) {
        o.trajectoryInterval = *interval;
        // Frames are taken on coarse steps: at the first one at or after each multiple of the
        // interval. Shorter than a step, or between two, is allowed but rarely what was meant.
        const double dt = ctx.spec.deltaTime;
        const double steps = *interval / dt;
        if (*interval < dt * (1 - 1e-9))
            ctx.diags.warning(r.loc("trajectory_interval"),
                              "Output@trajectory_interval (" + *r.text("trajectory_interval") +
                                  " s) is shorter than delta_time (" + shortestText(dt) +
                                  " s): trajectories are recorded every coarse step");
        else if (std::fabs(steps - std::round(steps)) > 1e-9 * steps)
            ctx.diags.warning(r.loc("trajectory_interval"),
                              "Output@trajectory_interval (" + *r.text("trajectory_interval") +
                                  " s) is not a whole multiple of delta_time (" + shortestText(dt) +
                                  " s): frames are taken at the first coarse step at or after each multiple, "
                                  "so they are unevenly spaced");
    }
    o.trajectoryVelocities = r.value("trajectory_velocities") != 0.0;
    o.flowFirst = static_cast<int>(r.value("flow_first"));
    o.flowLast = static_cast<int>(r.value("flow_last"));
    // A flow needs two distinct evacuees: (last − first)/(t_last − t_first).
    if (o.flowLast <= o.flowFirst)
        r.error(r.loc("flow_last"), "Output@flow_last: " + std::to_string(o.flowLast) +
                                        " must be greater than flow_first (" + std::to_string(o.flowFirst) + ")");
}

/// <Safety>: the verdict's thresholds and the grid of the crowd measures (safetyTable()).
void readSafety(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "Safety", safetyTable());
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    SafetyThresholds& t = ctx.spec.safety;
    t.cellSize = r.value("cell_size");
    t.gaussianRadius = r.value("gaussian_radius");
    t.densityCaution = r.value("density_caution");
    t.densityDangerous = r.value("density_dangerous");
    t.densityCritical = r.value("density_critical");
    t.crowdPressureCritical = r.value("crowd_pressure");
    t.pressureWindow = r.value("pressure_window");
    t.minDuration = r.value("min_duration");
    t.doseDangerousFraction = r.value("dose_dangerous_fraction");
    t.flowCapacity = r.value("flow_capacity");
    t.flowWindow = r.value("flow_window");
    // The three density levels must rise, or a level would never be reported. The message names
    // both values as written (or the default) at the attribute that breaks the order.
    auto shown = [&](const char* attr, double v) {
        const std::optional<std::string> raw = r.text(attr);
        return raw ? *raw : shortestText(v) + ", the default";
    };
    auto ordered = [&](const char* lowName, double low, const char* highName, double high) {
        if (high > low) return;
        const char* at = r.has(highName) ? highName : lowName;
        r.error(r.loc(at), std::string("Safety@") + highName + " (" + shown(highName, high) +
                               ") must be greater than " + lowName + " (" + shown(lowName, low) + ")");
    };
    ordered("density_caution", t.densityCaution, "density_dangerous", t.densityDangerous);
    ordered("density_dangerous", t.densityDangerous, "density_critical", t.densityCritical);
}

/// Simulation@seed: a whole number ≥ 0 that may use all 64 bits (so not through a double).
std::optional<std::uint64_t> readSeed(ElementReader& r) {
    const std::optional<std::string> raw = r.text("seed");
    if (!raw) return std::nullopt;
    std::string t = *raw;
    const auto first = t.find_first_not_of(" \t\r\n");
    const auto last = t.find_last_not_of(" \t\r\n");
    t = first == std::string::npos ? "" : t.substr(first, last - first + 1);
    std::uint64_t v = 0;
    auto res = std::from_chars(t.data(), t.data() + t.size(), v);
    if (t.empty() || res.ec != std::errc() || res.ptr != t.data() + t.size()) {
        r.error(r.loc("seed"), "Simulation@seed: '" + t + "' is not a whole number in [0, 18446744073709551615]");
        return std::nullopt;
    }
    return v;
}

void readSimulation(LoadContext& ctx, const std::string& file, const XMLElement* el, const LoadOptions& options) {
    ElementReader r(ctx, file, el, "Simulation", simulationTable(), {"seed"});
    ScenarioSpec& s = ctx.spec;
    // The seed first: generators inside <Agents> draw from it.
    const std::optional<std::uint64_t> seed = readSeed(r);
    s.seed = options.seed ? *options.seed : seed.value_or(1);

    const auto dt = r.required("delta_time");
    if (dt) s.deltaTime = *dt;
    const auto fine = r.optional("delta_time_fine");
    if (fine) s.deltaTimeFine = *fine;
    if (const auto end = r.optional("end_time")) s.endTime = *end;
    s.symmetryBreaking = r.value("symmetry_breaking");
    if (dt && fine) {
        // Whole number of fine steps per coarse step, with a relative tolerance for decimal input.
        const double ratio = *dt / *fine;
        const double n = std::round(ratio);
        if (*fine > *dt * (1 + 1e-9))
            r.error(r.loc("delta_time_fine"), "Simulation@delta_time_fine: " + *r.text("delta_time_fine") +
                                                  " s is larger than delta_time (" + *r.text("delta_time") + " s)");
        else if (std::fabs(*dt - n * *fine) > 1e-9 * *dt)
            r.error(r.loc("delta_time_fine"), "Simulation: delta_time (" + *r.text("delta_time") +
                                                  " s) is not a whole multiple of delta_time_fine (" +
                                                  *r.text("delta_time_fine") + " s)");
    }

    // Plugins first: the policies below may use their components.
    readPlugins(ctx, file, el);
    const XMLElement* world = nullptr;
    const XMLElement* output = nullptr;
    const XMLElement* safety = nullptr;
    // <World>, <Output> and <Safety> may appear once: a second one is reported and skipped.
    auto first = [&](const XMLElement*& seen, const XMLElement* c, const char* name) {
        if (seen != nullptr) {
            ctx.diags.error(locOf(file, c), std::string("more than one <") + name + "> (the first is at line " +
                                                std::to_string(seen->GetLineNum()) + ")");
            return false;
        }
        seen = c;
        return true;
    };
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (is(c, "World")) {
            if (first(world, c, "World")) readWorld(ctx, file, c);
        } else if (is(c, "Output")) {
            if (first(output, c, "Output")) readOutput(ctx, file, c);
        } else if (is(c, "Safety")) {
            if (first(safety, c, "Safety")) readSafety(ctx, file, c);
        } else if (is(c, "Policies")) {
            readBlock(ctx, file, c, Block::Policies, false);
        } else if (is(c, "Agents")) {
            readBlock(ctx, file, c, Block::Agents, false);
        } else if (is(c, "Obstacles")) {
            // UMANS reads obstacles only inside <World>; accepting them here as well is harmless.
            readBlock(ctx, file, c, Block::Obstacles, false);
        } else if (is(c, "Schedule")) {
            readSchedule(ctx, file, c);
        } else if (is(c, "Measurement")) {
            readMeasurement(ctx, file, c);
        } else if (is(c, "Plugin")) {
            // read first, by readPlugins
        } else {
            reportUnexpectedElement(ctx, file, c, el->Name(),
                                    {"World", "Policies", "Agents", "Obstacles", "Output", "Safety", "Schedule",
                                     "Measurement", "Plugin"});
        }
    }
    if (world == nullptr) ctx.diags.error(r.loc(), "Simulation: missing required element <World>");
}

// ---------------------------------------------------------------------------------------------
// Whole-scenario checks

/// Agent ids: explicit ids are kept (a repeated one is an error); the others get, in file order,
/// the next id not used so far — UMANS' rule, except that an explicit id always wins over an
/// automatic one (UMANS would renumber whichever came second).
void assignAgentIds(LoadContext& ctx) {
    std::map<AgentId, SourceLoc> explicitIds;
    for (std::size_t i = 0; i < ctx.spec.agents.size(); ++i) {
        if (!ctx.agentOrigins[i].explicitId) continue;
        const AgentId id = ctx.spec.agents[i].id;
        auto [it, inserted] = explicitIds.emplace(id, ctx.agentOrigins[i].idLoc);
        if (!inserted)
            ctx.diags.error(ctx.agentOrigins[i].idLoc,
                            "duplicate agent id " + std::to_string(id) + " (first used at " + it->second.file +
                                ":" + std::to_string(it->second.line) + ")");
    }
    AgentId next = 0;
    for (std::size_t i = 0; i < ctx.spec.agents.size(); ++i) {
        AgentSpec& a = ctx.spec.agents[i];
        if (!ctx.agentOrigins[i].explicitId) {
            while (explicitIds.count(next) != 0) ++next;
            a.id = next;
        }
        next = std::max(next, a.id + 1);
    }
}

/// Social groups: each distinct Agent@group name (and each group of an AgentGrid@group_size) gets
/// an index, in the order of its first member. A group of one is a warning (that agent walks as a
/// group of one: nobody to keep together with); more members than a group holds is an error.
void assignGroups(LoadContext& ctx) {
    constexpr std::size_t kMaxMembers = 20;  // AgentGrid@group_size's upper bound too
    std::map<std::string, int> index;
    std::vector<std::size_t> members;
    std::vector<SourceLoc> firstLoc;
    for (AgentSpec& a : ctx.spec.agents) {
        if (a.group.empty()) continue;
        auto [it, inserted] = index.emplace(a.group, static_cast<int>(ctx.spec.groups.size()));
        if (inserted) {
            ctx.spec.groups.push_back(a.group);
            members.push_back(0);
            firstLoc.push_back(a.loc);
        }
        a.groupIndex = it->second;
        if (++members[static_cast<std::size_t>(it->second)] == kMaxMembers + 1)
            ctx.diags.error(a.loc, "group '" + a.group + "' has more than " + std::to_string(kMaxMembers) +
                                       " members (families and friends walk in groups of 2-5, ISO 20414's group test has 15; a larger party is several groups)");
    }
    for (std::size_t g = 0; g < members.size(); ++g)
        if (members[g] == 1)
            ctx.diags.warning(firstLoc[g], "group '" + ctx.spec.groups[g] + "' has one member: nobody to walk with");
}

void checkPolicyRefs(LoadContext& ctx) {
    if (ctx.policiesIncomplete) return;  // already reported: the policies file could not be read
    std::string known;
    for (const auto& [id, loc] : ctx.policyIds) known += (known.empty() ? "" : ", ") + std::to_string(id);
    for (const LoadContext::PolicyRef& ref : ctx.policyRefs)
        if (ctx.policyIds.count(ref.id) == 0)
            ctx.diags.error(ref.loc, "Policy@id: policy " + std::to_string(ref.id) + " does not exist (defined: " +
                                         (known.empty() ? "none" : known) + ")");
}

/// What a run would need, checked before anything is simulated: coordinates the grids can cover,
/// memory for the agents, and the number of steps (docs/user-guide.md, "Limits").
void checkResources(LoadContext& ctx, const std::string& path, const SourceLoc& simulationLoc) {
    // The neighbour grids and the safety grid work in cells of about a metre; a coordinate of
    // 1e15 m would ask for more cells than any machine holds (and overflow their indices).
    constexpr double kMaxCoordinate = 1e6;  // m: 1000 km, far beyond any venue (UMANS' far goals are 50 km)
    const auto far = [&](const Vec2& p) { return !(std::abs(p.x()) <= kMaxCoordinate && std::abs(p.y()) <= kMaxCoordinate); };
    const auto at = [](const Vec2& p) { return "(" + formatNumber(p.x()) + ", " + formatNumber(p.y()) + ") m"; };
    const std::string why = ": coordinates must lie within ±" + formatNumber(kMaxCoordinate) +
                            " m (1000 km): the neighbour and safety grids could not cover a wider area";
    int reported = 0;
    for (const AgentSpec& a : ctx.spec.agents) {
        if (reported >= 5) break;
        if (far(a.position)) {
            ctx.diags.error(a.loc, "agent " + std::to_string(a.id) + " starts at " + at(a.position) + why);
            ++reported;
        } else if (a.goal && far(*a.goal)) {
            ctx.diags.error(a.loc, "agent " + std::to_string(a.id) + " has its goal at " + at(*a.goal) + why);
            ++reported;
        }
    }
    for (const ObstacleSpec& o : ctx.spec.obstacles)
        for (const Vec2& p : o.points)
            if (reported < 5 && far(p)) {
                ctx.diags.error(o.loc, "obstacle point at " + at(p) + why);
                ++reported;
                break;
            }

    // Memory: about 1 KiB per agent in a run (state, neighbour lists, health record; the 1M-agent
    // crowd of the benchmark peaks at 998 MiB), against the machine's physical memory.
    const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGE_SIZE);
    const double agents = static_cast<double>(ctx.spec.agents.size());
    const double need = agents * 1024.0;
    if (pages > 0 && pageSize > 0) {
        const double have = static_cast<double>(pages) * static_cast<double>(pageSize);
        const std::string numbers = formatNumber(agents) + " agents need about " + formatNumber(need / (1 << 20), 3) +
                                    " MiB; this machine has " + formatNumber(have / (1 << 20), 3) + " MiB";
        if (need > have)
            ctx.diags.error(simulationLoc, numbers + ": the run cannot fit in memory");
        else if (need > 0.5 * have)
            ctx.diags.warning(simulationLoc, numbers + ": the run may exhaust memory");
    }

    // Steps: warn when the run is absurdly long for its time step (1e8 fine steps take hours
    // even for a single agent).
    const double dt = ctx.spec.fineStep();
    if (dt > 0 && ctx.spec.endTime > 0) {
        const double steps = ctx.spec.endTime / dt;
        if (steps >= 1e8)
            ctx.diags.warning(simulationLoc, "end_time " + formatNumber(ctx.spec.endTime) + " s in fine steps of " +
                                                 formatNumber(dt) + " s is " + formatNumber(steps, 3) +
                                                 " steps: at least " + formatNumber(steps * 1e-6 / 3600.0, 2) +
                                                 " hours even for one agent (about 1 µs per step); check delta_time");
    }
    (void)path;
}

}  // namespace

}  // namespace xmlio

const ParamTable& simulationTable() {
    static const ParamTable t = [] {
        ParamTable table = {
            ParamSpec::real("delta_time", "s", 0.1, 0, 1e300, "coarse time step (UMANS' only step)"),
            ParamSpec::real("delta_time_fine", "s", 0, 0, 1e300,
                            "fine time step of force-based steps; delta_time must be a whole multiple"),
            ParamSpec::real("end_time", "s", -1, 0, 1e300,
                            "simulated duration; absent: until every agent has left"),
        };
        for (ParamSpec& p : table) p.minExclusive = true;
        table.push_back(ParamSpec::real(
            "symmetry_breaking", "m", ScenarioSpec::kDefaultSymmetryBreaking, 0, 0.01,
            "largest seeded displacement per step of an agent slower than half its preferred speed, breaks "
            "exact symmetries; 0 = off"));
        return table;
    }();
    return t;
}

std::optional<ScenarioSpec> loadScenario(const std::string& path, Diagnostics& diags, const LoadOptions& options) {
    using namespace xmlio;
    const int errorsBefore = diags.errorCount();
    ScenarioSpec spec;
    spec.sourceFile = path;
    spec.seed = options.seed.value_or(1);
    LoadContext ctx(diags, spec);

    tinyxml2::XMLDocument doc;
    if (options.text) {
        if (!parseDocumentText(ctx, path, *options.text, doc)) return std::nullopt;
    } else if (!loadDocument(ctx, path, nullptr, path, doc)) {
        return std::nullopt;
    }

    const XMLElement* simulation = nullptr;
    for (const XMLElement* top = doc.FirstChildElement(); top != nullptr; top = top->NextSiblingElement()) {
        if (is(top, "Simulation")) {
            if (simulation != nullptr)
                diags.error(locOf(path, top), "more than one <Simulation> in one file (the first is at line " +
                                                  std::to_string(simulation->GetLineNum()) + ")");
            else
                simulation = top;
        } else if (is(top, "Agents") || is(top, "Policies") || is(top, "Obstacles")) {
            // UMANS reads only what is inside <Simulation>; say so rather than silently dropping it.
            diags.warning(locOf(path, top), std::string("<") + top->Name() +
                                                "> outside <Simulation> is ignored; move it inside <Simulation>");
        } else {
            reportUnexpectedElement(ctx, path, top, "", {"Simulation"});
        }
    }
    if (simulation == nullptr) {
        diags.error(SourceLoc{path, 0}, "no <Simulation> element: not a scenario file");
        return std::nullopt;
    }
    readSimulation(ctx, path, simulation, options);

    checkVenue(ctx);
    assignAgentIds(ctx);
    assignGroups(ctx);
    checkPolicyRefs(ctx);
    checkSchedule(ctx);
    checkWallModels(ctx);
    checkResources(ctx, path, locOf(path, simulation));
    if (ctx.policyIds.empty() && !ctx.policiesIncomplete)
        diags.error(locOf(path, simulation),
                    "no policy defined: a scenario needs a <Policies> block with at least one <Policy>");
    if (spec.agents.empty() && !ctx.agentsIncomplete)
        diags.warning(locOf(path, simulation), "no agents: the simulation starts empty");

    if (diags.errorCount() > errorsBefore) return std::nullopt;
    return spec;
}

}  // namespace ch
