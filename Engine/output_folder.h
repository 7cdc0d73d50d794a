// crowdhealth — the output folder's rules: never lose a user's file, never leave stale outputs.
//
// Every folder the program writes a run into holds a manifest, `.crowdhealth-manifest`: one name
// per line of the files (and, ending in '/', the sub-folders such as run_000/) that the program
// wrote there. With it:
//
// * before a run, the folder is checked: an entry that is neither in the manifest, nor the
//   manifest, nor a `<name>.tmp` left by a killed run of ours, is a file the program does not
//   know; the run is refused (exit 2) unless --overwrite is given;
// * before writing, the manifest becomes old ∪ new names (so a run killed while writing leaves
//   no file the next run would not know); after writing, the files of the old manifest that the
//   new run did not write are removed (a sub-folder: the files of its own manifest, then the
//   folder if it is empty), our `*.tmp` leftovers too, and the manifest becomes the new names;
// * commands that write into such a folder afterwards (`crowdhealth plot`, `compare -o`,
//   `render -o`) add their files to its manifest, so the next run replaces them too.
//
// Nothing that is not in a manifest (or one of our .tmp names) is ever deleted.
#pragma once

#include <filesystem>
#include <set>
#include <string>
#include <vector>

namespace chcli {

/// The manifest's file name.
inline constexpr const char* kManifestName = ".crowdhealth-manifest";

class OutputFolder {
public:
    /// Reads the manifest of `dir` (none: an empty one). The folder need not exist.
    explicit OutputFolder(std::filesystem::path dir);

    const std::filesystem::path& dir() const { return dir_; }
    /// The names the manifest lists (sub-folders end in '/').
    const std::set<std::string>& previous() const { return previous_; }
    bool hasManifest() const { return hasManifest_; }

    /// The entries of the folder the program does not know (sorted; sub-folders end in '/').
    std::vector<std::string> unknownEntries() const;

    /// Before writing `names`: the manifest lists the previous names and these.
    void announce(const std::vector<std::string>& names);
    /// After writing `names`: removes the previous names that are not among them and our *.tmp
    /// leftovers, then writes the manifest with exactly `names`. Returns the problems met while
    /// removing (a file that could not be removed), one message each; never throws for those.
    /// Throws ch::OutputError when the manifest cannot be written.
    std::vector<std::string> settle(const std::vector<std::string>& names);

private:
    std::filesystem::path dir_;
    std::set<std::string> previous_;
    bool hasManifest_ = false;

    void writeManifest(const std::set<std::string>& names) const;
};

/// The error text for a folder holding files the program does not know: the folder, up to five
/// names, and what to do (no trailing newline).
std::string unknownEntriesMessage(const std::filesystem::path& dir, const std::vector<std::string>& unknown);

/// Adds `file` to the manifest of the folder it is in, when that folder has a manifest (a run
/// folder); otherwise does nothing. Never throws: returns false when the manifest could not be
/// updated.
bool addToManifest(const std::filesystem::path& file);
/// The same for several files of the folder `dir` at once.
bool addToManifest(const std::filesystem::path& dir, const std::vector<std::string>& names);

}  // namespace chcli
