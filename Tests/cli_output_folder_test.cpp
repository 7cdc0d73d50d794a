// The output folder's rules (docs/user-guide.md, "The output folder"): a run into a folder that
// holds an earlier run replaces exactly the files of that run's manifest (.crowdhealth-manifest),
// leaving no stale file; a folder holding files crowdhealth did not write is refused with exit
// status 2 unless --overwrite, which writes ours and keeps theirs; nothing the program did not
// write is ever deleted; *.tmp leftovers of a killed run are ours; files `crowdhealth plot` adds
// to a run folder join its manifest.
#define BOOST_TEST_MODULE cli_output_folder
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <set>

using namespace clitest;

namespace {

const std::vector<std::string> kRunFiles = {".crowdhealth-manifest", "evacuations.csv", "health.csv",
                                            "heatmap.csv", "metrics.csv", "summary.json"};

std::vector<std::string> with(std::vector<std::string> v, const std::vector<std::string>& more) {
    v.insert(v.end(), more.begin(), more.end());
    std::sort(v.begin(), v.end());
    return v;
}

/// The manifest lists every file of the folder but itself.
void manifestMatchesFolder(const fs::path& dir) {
    std::vector<std::string> expected;
    for (const std::string& e : entriesOf(dir))
        if (e != ".crowdhealth-manifest") expected.push_back(e);
    BOOST_TEST(manifestOf(dir) == expected, dir);
}

Result runInto(const fs::path& dir, const std::string& out, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"-i", testData("evacuation.xml"), "-o", out, "-t", "1", "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return run(dir, args);
}

}  // namespace

BOOST_AUTO_TEST_CASE(a_new_run_replaces_exactly_the_files_of_the_previous_one) {
    const fs::path dir = freshDir(caseName());
    Result r = runInto(dir, "out", {"--trajectories", "umans,txt,bin"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    std::vector<std::string> trajectories = {"trajectories.bin", "trajectories.txt"};
    for (int id = 0; id < 10; ++id) trajectories.push_back("output_" + std::to_string(id) + ".csv");
    BOOST_TEST(entriesOf(dir / "out") == with(kRunFiles, trajectories));
    manifestMatchesFolder(dir / "out");

    // Without trajectories: the earlier run's trajectory files are gone, not left stale.
    r = runInto(dir, "out", {"--end-time", "2"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(entriesOf(dir / "out") == kRunFiles);
    manifestMatchesFolder(dir / "out");
    BOOST_TEST(readFile(dir / "out" / "summary.json").find("\"simulated_time\": 2,") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(a_folder_with_files_crowdhealth_did_not_write_is_refused_and_left_as_it_was) {
    const fs::path dir = freshDir(caseName());
    BOOST_REQUIRE(runInto(dir, "out", {"--trajectories", "txt"}).status == 0);
    std::ofstream(dir / "out" / "notes.txt") << "my notes\n";
    fs::create_directories(dir / "out" / "mine");
    const std::string summary = readFile(dir / "out" / "summary.json");
    const auto before = entriesOf(dir / "out");

    const Result r = runInto(dir, "out", {"--end-time", "2"});
    BOOST_TEST(r.status == 2, r.err);
    BOOST_TEST(r.err.find("'out' holds 2 files or folders that crowdhealth did not write (mine/, notes.txt)") !=
                   std::string::npos, r.err);
    BOOST_TEST(r.err.find("--overwrite") != std::string::npos, r.err);
    BOOST_TEST(entriesOf(dir / "out") == before);  // nothing written, nothing removed
    BOOST_TEST(readFile(dir / "out" / "summary.json") == summary);
    BOOST_TEST(r.out.empty(), r.out);

    // A folder of someone else's files, never used by crowdhealth: refused just the same.
    fs::create_directories(dir / "theirs");
    std::ofstream(dir / "theirs" / "data.csv") << "1,2\n";
    BOOST_TEST(runInto(dir, "theirs").status == 2);
    BOOST_TEST(entriesOf(dir / "theirs") == std::vector<std::string>{"data.csv"});
    // An empty folder is fine.
    fs::create_directories(dir / "empty");
    BOOST_TEST(runInto(dir, "empty").status == 0);
}

BOOST_AUTO_TEST_CASE(overwrite_writes_ours_and_keeps_theirs) {
    const fs::path dir = freshDir(caseName());
    BOOST_REQUIRE(runInto(dir, "out", {"--trajectories", "txt"}).status == 0);
    std::ofstream(dir / "out" / "notes.txt") << "my notes\n";
    fs::create_directories(dir / "out" / "mine");
    std::ofstream(dir / "out" / "mine" / "a.txt") << "a\n";

    const Result r = runInto(dir, "out", {"--end-time", "2", "--overwrite"});
    BOOST_TEST(r.status == 0, r.err);
    // The earlier run's trajectories.txt is gone (ours, stale); the user's files are all there.
    BOOST_TEST(entriesOf(dir / "out") == with(kRunFiles, {"mine/", "notes.txt"}));
    BOOST_TEST(readFile(dir / "out" / "notes.txt") == "my notes\n");
    BOOST_TEST(readFile(dir / "out" / "mine" / "a.txt") == "a\n");
    // The manifest lists only ours, so the next run still refuses theirs.
    BOOST_TEST(manifestOf(dir / "out") == with({"evacuations.csv", "health.csv", "heatmap.csv", "metrics.csv",
                                                "summary.json"}, {}));
    BOOST_TEST(runInto(dir, "out").status == 2);
}

BOOST_AUTO_TEST_CASE(nothing_outside_the_manifest_is_ever_deleted) {
    const fs::path dir = freshDir(caseName());
    BOOST_REQUIRE(runInto(dir, "out").status == 0);
    // A manifest that names files outside its folder, or a folder it never wrote, is not obeyed.
    // (Only files of this test's own folder are named: if the rule broke, nothing else is lost.)
    std::ofstream(dir / "victim.txt") << "keep\n";
    std::ofstream(dir / "absolute.txt") << "keep\n";
    fs::create_directories(dir / "out" / "sub");
    std::ofstream(dir / "out" / "sub" / "keep.txt") << "keep\n";
    std::ofstream(dir / "out" / ".crowdhealth-manifest", std::ios::app)
        << "../victim.txt\n" << (dir / "absolute.txt").string() << "\nsub/\n";
    const Result r = runInto(dir, "out", {"--overwrite"});
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(fs::exists(dir / "victim.txt"));
    BOOST_TEST(fs::exists(dir / "absolute.txt"));
    BOOST_TEST(readFile(dir / "out" / "sub" / "keep.txt") == "keep\n");  // "sub/" had no manifest of ours
}

BOOST_AUTO_TEST_CASE(tmp_leftovers_of_a_killed_run_are_ours_and_cleaned_up) {
    const fs::path dir = freshDir(caseName());
    BOOST_REQUIRE(runInto(dir, "out").status == 0);
    // What a run killed with SIGKILL leaves: the streamed trajectories and a file being written.
    std::ofstream(dir / "out" / "trajectories.bin.tmp") << "half";
    std::ofstream(dir / "out" / "metrics.csv.tmp") << "half";
    std::ofstream(dir / "out" / "output_7.csv.tmp") << "half";
    Result r = runInto(dir, "out");
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(entriesOf(dir / "out") == kRunFiles);
    BOOST_TEST(tmpFiles(dir / "out").empty());
    // A .tmp of a name the program does not write is someone else's.
    std::ofstream(dir / "out" / "draft.tmp") << "mine";
    r = runInto(dir, "out");
    BOOST_TEST(r.status == 2, r.err);
    BOOST_TEST(r.err.find("draft.tmp") != std::string::npos, r.err);
}

BOOST_AUTO_TEST_CASE(replications_and_single_runs_replace_each_other) {
    const fs::path dir = freshDir(caseName());
    Result r = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "--replications", "3", "-t", "2", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(entriesOf(dir / "out") ==
               with({".crowdhealth-manifest", "summary.csv"}, {"run_000/", "run_001/", "run_002/"}));
    manifestMatchesFolder(dir / "out");
    for (const char* k : {"run_000", "run_001", "run_002"}) {
        BOOST_TEST(entriesOf(dir / "out" / k) == kRunFiles, k);
        manifestMatchesFolder(dir / "out" / k);
    }

    // A user's file inside a run folder refuses the next set, naming it.
    std::ofstream(dir / "out" / "run_002" / "notes.txt") << "mine\n";
    r = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "--replications", "3", "-t", "2", "-q"});
    BOOST_TEST(r.status == 2, r.err);
    BOOST_TEST(r.err.find("run_002/notes.txt") != std::string::npos, r.err);

    // Two replications with --overwrite: run_002 was ours and is stale; its files go, the user's
    // file (and so the folder) stays.
    r = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "--replications", "2", "-t", "2", "-q", "--overwrite"});
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(entriesOf(dir / "out" / "run_002") == std::vector<std::string>{"notes.txt"});
    fs::remove_all(dir / "out" / "run_002");

    // A single run into it: the run folders and summary.csv go.
    r = runInto(dir, "out");
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(entriesOf(dir / "out") == kRunFiles);
    // And a set into a single run's folder: the single run's files go.
    r = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "--replications", "2", "-t", "2", "-q"});
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(entriesOf(dir / "out") == with({".crowdhealth-manifest", "summary.csv"}, {"run_000/", "run_001/"}));
}

BOOST_AUTO_TEST_CASE(plots_drawn_into_a_run_folder_join_its_manifest) {
    if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
        BOOST_TEST_MESSAGE("gnuplot missing: not checked");
        return;
    }
    const fs::path dir = freshDir(caseName());
    BOOST_REQUIRE(runInto(dir, "out").status == 0);
    Result r = run(dir, {"plot", "out", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(fs::exists(dir / "out" / "fig3.png"));
    manifestMatchesFolder(dir / "out");
    // The next run is not refused, and the figures of the earlier run do not stay beside it.
    r = runInto(dir, "out", {"--end-time", "2"});
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(entriesOf(dir / "out") == kRunFiles);
    // With --plot the figures are part of the run.
    r = runInto(dir, "out", {"--plot"});
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(fs::exists(dir / "out" / "fig3.png"));
    manifestMatchesFolder(dir / "out");
}
