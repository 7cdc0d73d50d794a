// crowdhealth — the output folder's rules (see output_folder.h).
#include "output_folder.h"

#include <crowdhealth/io/output.h>

#include <algorithm>
#include <fstream>
#include <regex>
#include <system_error>

namespace chcli {

namespace fs = std::filesystem;

namespace {

constexpr const char* kManifestHeader =
    "# crowdhealth: the files it wrote into this folder (sub-folders end in /); a new run replaces "
    "exactly these. Do not edit.";

/// The names the program writes, whatever the manifest says: a `<name>.tmp` of one of these is a
/// leftover of ours (a run killed before it renamed the file, or before its first manifest).
bool isOutputName(const std::string& name) {
    static const std::regex known(
        R"(^(metrics\.csv|evacuations\.csv|health\.csv|heatmap\.csv|summary\.json|summary\.csv|)"
        R"(trajectories\.txt|trajectories\.bin|output_-?[0-9]+\.csv|fig3\.png|health\.png|schedule\.png|)"
        R"(heatmap\.png|(fig3|health|schedule|heatmap|compare)\.png\.log|compare\.md|compare\.csv|compare\.png|render\.json|render\.gp|render-data\.txt|frame_[0-9]+\.png|)"
        R"(animation\.gif|animation\.mp4|\.crowdhealth-manifest|\.crowdhealth-write-test)$)");
    return std::regex_match(name, known);
}

bool endsWith(const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

std::set<std::string> readManifest(const fs::path& dir, bool& found) {
    std::set<std::string> names;
    std::ifstream in(dir / kManifestName);
    found = static_cast<bool>(in);
    std::string line;
    while (std::getline(in, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty() || line[0] == '#') continue;
        // Only plain names inside this folder: a manifest edited to say "../x" or "/etc/x" must
        // not make the program delete anything outside it.
        const std::string bare = endsWith(line, "/") ? line.substr(0, line.size() - 1) : line;
        if (bare.empty() || bare == "." || bare == ".." || bare.find('/') != std::string::npos) continue;
        names.insert(line);
    }
    return names;
}

/// The entry's name as the manifest lists it: sub-folders end in '/'.
std::string entryName(const fs::directory_entry& e) {
    std::error_code ec;
    const bool dir = e.is_directory(ec) && !e.is_symlink(ec);
    return e.path().filename().string() + (dir ? "/" : "");
}

/// Removes what the program wrote into the sub-folder `dir` (the names of its manifest,
/// recursively, its *.tmp leftovers and the manifest), then the folder if nothing else is left.
void removeOurFolder(const fs::path& dir, std::vector<std::string>& problems);

/// Removes the entry `name` (from a manifest) of `dir` if it is there.
void removeOurEntry(const fs::path& dir, const std::string& name, std::vector<std::string>& problems) {
    std::error_code ec;
    if (endsWith(name, "/")) {
        const fs::path sub = dir / name.substr(0, name.size() - 1);
        if (fs::is_directory(fs::symlink_status(sub, ec))) removeOurFolder(sub, problems);
        return;
    }
    const fs::path file = dir / name;
    const fs::file_status st = fs::symlink_status(file, ec);
    if (ec || !fs::exists(st) || fs::is_directory(st)) return;  // gone, or not the file we wrote
    if (!fs::remove(file, ec) && ec) problems.push_back("cannot remove " + file.string() + ": " + ec.message());
}

void removeLeftovers(const fs::path& dir, const std::set<std::string>& ours, std::vector<std::string>& problems) {
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (!endsWith(name, ".tmp") || !it->is_regular_file(ec)) continue;
        const std::string stem = name.substr(0, name.size() - 4);
        if (!ours.count(stem) && !isOutputName(stem)) continue;
        std::error_code rec;
        if (!fs::remove(it->path(), rec) && rec)
            problems.push_back("cannot remove " + it->path().string() + ": " + rec.message());
    }
}

void removeOurFolder(const fs::path& dir, std::vector<std::string>& problems) {
    bool found = false;
    const std::set<std::string> names = readManifest(dir, found);
    for (const std::string& n : names) removeOurEntry(dir, n, problems);
    removeLeftovers(dir, names, problems);
    std::error_code ec;
    fs::remove(dir / kManifestName, ec);
    fs::remove(dir, ec);  // fails (and is meant to) when something not ours is left in it
}

}  // namespace

OutputFolder::OutputFolder(fs::path dir) : dir_(std::move(dir)) { previous_ = readManifest(dir_, hasManifest_); }

std::vector<std::string> OutputFolder::unknownEntries() const {
    std::vector<std::string> unknown;
    std::error_code ec;
    if (!fs::is_directory(dir_, ec)) return unknown;
    for (fs::directory_iterator it(dir_, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = entryName(*it);
        if (previous_.count(name) || name == kManifestName) continue;
        if (endsWith(name, ".tmp")) {
            const std::string stem = name.substr(0, name.size() - 4);
            if (previous_.count(stem) || isOutputName(stem)) continue;  // a leftover of a killed run
        }
        unknown.push_back(name);
    }
    if (ec) unknown.push_back("(the folder cannot be listed: " + ec.message() + ")");
    std::sort(unknown.begin(), unknown.end());
    return unknown;
}

void OutputFolder::writeManifest(const std::set<std::string>& names) const {
    std::string text = kManifestHeader;
    text += '\n';
    for (const std::string& n : names) text += n + '\n';
    ch::writeFileAtomic(dir_ / kManifestName, text);
}

void OutputFolder::announce(const std::vector<std::string>& names) {
    std::set<std::string> all = previous_;
    all.insert(names.begin(), names.end());
    writeManifest(all);
}

std::vector<std::string> OutputFolder::settle(const std::vector<std::string>& names) {
    const std::set<std::string> now(names.begin(), names.end());
    std::vector<std::string> problems;
    for (const std::string& n : previous_)
        if (!now.count(n)) removeOurEntry(dir_, n, problems);
    std::set<std::string> ours = previous_;
    ours.insert(now.begin(), now.end());
    removeLeftovers(dir_, ours, problems);
    writeManifest(now);
    previous_ = now;
    hasManifest_ = true;
    return problems;
}

std::string unknownEntriesMessage(const fs::path& dir, const std::vector<std::string>& unknown) {
    std::string list;
    const std::size_t shown = std::min<std::size_t>(unknown.size(), 5);
    for (std::size_t i = 0; i < shown; ++i) list += (i ? ", " : "") + unknown[i];
    if (unknown.size() > shown) list += " and " + std::to_string(unknown.size() - shown) + " more";
    return "the output folder '" + dir.string() + "' holds " + std::to_string(unknown.size()) +
           (unknown.size() == 1 ? " file or folder" : " files or folders") + " that crowdhealth did not write (" + list +
           "); nothing was run or written. Choose an empty or new folder, or give --overwrite to write into it anyway "
           "(its own files are kept; only files with the names of this run's outputs are replaced)";
}

bool addToManifest(const fs::path& dir, const std::vector<std::string>& names) {
    OutputFolder folder(dir.empty() ? fs::path(".") : dir);
    if (!folder.hasManifest()) return true;
    if (std::all_of(names.begin(), names.end(), [&](const std::string& n) { return folder.previous().count(n) > 0; }))
        return true;
    try {
        folder.announce(names);
    } catch (const std::exception&) {
        return false;
    }
    return true;
}

bool addToManifest(const fs::path& file) { return addToManifest(file.parent_path(), {file.filename().string()}); }

}  // namespace chcli
