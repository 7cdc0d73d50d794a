// `mpirun -n K crowdhealth sweep …`: the same sweep.csv (apart from wall_time) and sweep-summary.csv
// as without MPI; rank 0 alone prints and writes; a failing run is marked failed while the others
// finish; a killed MPI sweep resumes from its records; errors in the arguments are printed once and
// every rank exits with the same status; `crowdhealth calibrate` gives the same search and result
// under MPI as without, and its errors are printed once too. Registered only when the program is built with MPI and
// mpirun is found (Tests/CMakeLists.txt). Tests/data/cli/doorway-small.xml: 42 agents leave a
// 6 x 6 m room through a door (seed 11, end time 20 s), the SPH model as policy 0.
#define BOOST_TEST_MODULE cli_sweep_mpi
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <map>

using namespace clitest;

namespace {

std::string scenario() { return testData("doorway-small.xml"); }

/// The 2 x 2 x 2 sweep of cli_sweep_test (progress and closing lines on: they must appear once).
const std::vector<std::string> kGrid = {"--vary", "0.SPH.restDensityMax=4,6", "--vary", "agents.pref_speed=1,1.6",
                                        "--replications", "2", "--seed", "5"};

std::vector<std::string> sweepArgs(const fs::path& out, const std::vector<std::string>& more) {
    std::vector<std::string> a = {"sweep", "-i", scenario(), "-o", out.string()};
    a.insert(a.end(), more.begin(), more.end());
    return a;
}

/// mpirun may run as root only when told so; the variables do that without a flag that a
/// non-root mpirun would not need.
void allowRoot() {
    setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
    setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
}

/// `mpirun -n ranks --oversubscribe crowdhealth args…` (2 cores, 3 ranks: oversubscribed). A rank
/// left waiting for a message that never comes would hang the test: mpirun ends it after 120 s.
std::vector<std::string> mpiArgs(int ranks, const std::vector<std::string>& args) {
    std::vector<std::string> a = {"-n", std::to_string(ranks), "--oversubscribe", "--timeout", "120", CH_BINARY};
    a.insert(a.end(), args.begin(), args.end());
    return a;
}

/// What `runMpi` gives: the program's result as mpirun passes it on, and each rank's exit status.
struct MpiResult : Result {
    std::vector<int> ranks;  ///< exit status of rank 0, 1, … (-1: not known)
};

/// `mpirun … crowdhealth args…` in `dir`. With `eachRank`, every rank runs through a shell that
/// writes its exit status to dir/_rankN.status (every rank must exit with the command's status,
/// not only rank 0), and mpirun is told not to end the other ranks when one exits with a status
/// other than 0 (it then exits 0 itself, so its status means nothing).
MpiResult runMpi(const fs::path& dir, int ranks, const std::vector<std::string>& args, bool eachRank = false) {
    allowRoot();
    std::vector<std::string> a = mpiArgs(ranks, args);
    if (eachRank) {
        setenv("OMPI_MCA_orte_abort_on_non_zero_status", "0", 1);
        for (int r = 0; r < ranks; ++r) fs::remove(dir / ("_rank" + std::to_string(r) + ".status"));
        const auto program = std::find(a.begin(), a.end(), std::string(CH_BINARY));
        a.insert(program, {"/bin/sh", "-c", "\"$0\" \"$@\"; s=$?; echo $s > _rank$OMPI_COMM_WORLD_RANK.status; exit $s"});
    } else {
        unsetenv("OMPI_MCA_orte_abort_on_non_zero_status");
    }
    MpiResult m;
    static_cast<Result&>(m) = runIn(dir, "", CH_MPIRUN, a);
    for (int r = 0; eachRank && r < ranks; ++r) {
        const std::string text = readFile(dir / ("_rank" + std::to_string(r) + ".status"));
        m.ranks.push_back(text.empty() ? -1 : std::stoi(text));
    }
    return m;
}

/// True when every rank exited with `status`.
bool allRanksExited(const MpiResult& m, int status) {
    return !m.ranks.empty() && std::all_of(m.ranks.begin(), m.ranks.end(), [&](int s) { return s == status; });
}

/// sweep.csv without its last column (wall_time).
std::string withoutWallTime(const std::string& text) {
    std::string out;
    for (const std::string& l : lines(text)) out += l.substr(0, l.rfind(',')) + "\n";
    return out;
}

std::size_t count(const std::string& text, const std::string& word) {
    std::size_t n = 0;
    for (auto at = text.find(word); at != std::string::npos; at = text.find(word, at + 1)) ++n;
    return n;
}

std::size_t records(const fs::path& out) {
    std::size_t n = 0;
    const fs::path dir = out / ".sweep" / "runs";
    if (fs::exists(dir))
        for (const auto& e : fs::directory_iterator(dir)) n += e.path().extension() == ".txt";
    return n;
}

/// The 2 x 2 x 2 sweep without MPI, once per process (the cases compare with it).
const fs::path& localGrid() {
    static const fs::path dir = [] {
        const fs::path d = freshDir("local-grid");
        auto a = kGrid;
        a.insert(a.end(), {"--jobs", "2", "--quiet"});
        const Result r = run(d, sweepArgs(d / "out", a));
        BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
        return d / "out";
    }();
    return dir;
}

/// mpirun, allowed to run as root, ending every rank when one fails (its default).
std::string mpirunForBackground() {
    allowRoot();
    unsetenv("OMPI_MCA_orte_abort_on_non_zero_status");
    return CH_MPIRUN;
}

/// `mpirun …` in the background, for the tests that kill it.
class MpiBackground : public Background {
public:
    MpiBackground(const fs::path& dir, const std::vector<std::string>& args) : Background(dir, mpirunForBackground(), args) {}
    /// The process of MPI rank `rank` (a child of mpirun, found through /proc), or -1.
    pid_t rankPid(int rank) const {
        for (const auto& e : fs::directory_iterator("/proc")) {
            const std::string name = e.path().filename().string();
            if (name.find_first_not_of("0123456789") != std::string::npos) continue;
            std::istringstream stat(readFile(e.path() / "stat"));
            std::string own, comm, state;
            pid_t parent = 0;
            stat >> own >> comm >> state >> parent;
            if (parent != pid()) continue;
            std::string environ = readFile(e.path() / "environ");
            std::replace(environ.begin(), environ.end(), '\0', '\n');
            if (("\n" + environ).find("\nOMPI_COMM_WORLD_RANK=" + std::to_string(rank) + "\n") != std::string::npos)
                return static_cast<pid_t>(std::stol(name));
        }
        return -1;
    }
};

}  // namespace

BOOST_AUTO_TEST_CASE(three_ranks_give_the_same_files_and_print_once) {
    const fs::path d = freshDir(caseName());
    const MpiResult r = runMpi(d, 3, sweepArgs(d / "out", kGrid));
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(withoutWallTime(readFile(d / "out" / "sweep.csv")) == withoutWallTime(readFile(localGrid() / "sweep.csv")));
    BOOST_TEST(readFile(d / "out" / "sweep-summary.csv") == readFile(localGrid() / "sweep-summary.csv"));
    BOOST_TEST(records(d / "out") == 8u);
    // One closing report, from rank 0, naming its two worker ranks; no work folders left.
    BOOST_TEST(count(r.out, "crowdhealth sweep:") == 1u, r.out);
    BOOST_TEST(r.out.find("on 2 MPI worker ranks") != std::string::npos, r.out);
    BOOST_TEST(r.err.find("crowdhealth") == std::string::npos, r.err);
    BOOST_TEST(fs::exists(d / "out" / "sweep-0.SPH.restDensityMax.png"));
    BOOST_TEST(!fs::exists(d / "out" / ".sweep" / "work"));
}

BOOST_AUTO_TEST_CASE(one_rank_runs_the_jobs_itself) {
    const fs::path d = freshDir(caseName());
    auto a = kGrid;
    a.insert(a.end(), {"--jobs", "2"});
    const Result r = runMpi(d, 1, sweepArgs(d / "out", a));
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(withoutWallTime(readFile(d / "out" / "sweep.csv")) == withoutWallTime(readFile(localGrid() / "sweep.csv")));
    BOOST_TEST(readFile(d / "out" / "sweep-summary.csv") == readFile(localGrid() / "sweep-summary.csv"));
    BOOST_TEST(r.out.find("at most 2 at a time)") != std::string::npos, r.out);  // local threads
}

BOOST_AUTO_TEST_CASE(a_failing_run_is_marked_and_the_others_finish) {
    const fs::path d = freshDir(caseName());
    const std::vector<std::string> args = {"--vary", "agents.pref_speed=1.2,1.4,1.6", "--end-time", "2",
                                           "--debug-fail-run", "1", "--quiet"};
    const Result local = run(d, sweepArgs(d / "local", args));
    BOOST_TEST(local.status == 1);
    const MpiResult r = runMpi(d, 3, sweepArgs(d / "out", args));
    BOOST_TEST(r.status == 1);
    const MpiResult each = runMpi(d, 3, sweepArgs(d / "each", args), true);
    BOOST_TEST(allRanksExited(each, 1));
    BOOST_TEST(count(r.err, "run 1 (seed 11) failed: failed on purpose") == 1u, r.err);
    const std::vector<std::string> rows = lines(readFile(d / "out" / "sweep.csv"));
    BOOST_REQUIRE_EQUAL(rows.size(), 4u);
    BOOST_TEST(rows[1].find(",11,ok,") != std::string::npos, rows[1]);
    BOOST_TEST(rows[2].find(",11,failed,,,,,,,,") != std::string::npos, rows[2]);
    BOOST_TEST(rows[3].find(",11,ok,") != std::string::npos, rows[3]);
    BOOST_TEST(withoutWallTime(readFile(d / "out" / "sweep.csv")) == withoutWallTime(readFile(d / "local" / "sweep.csv")));
    BOOST_TEST(readFile(d / "out" / "sweep-summary.csv") == readFile(d / "local" / "sweep-summary.csv"));
    BOOST_TEST(records(d / "out") == 2u);  // the failed run is tried again on resume
}

BOOST_AUTO_TEST_CASE(resume_from_records_under_mpi) {
    const fs::path d = freshDir(caseName());
    fs::copy(localGrid(), d / "out", fs::copy_options::recursive);
    const fs::path recs = d / "out" / ".sweep" / "runs";
    const std::string kept = readFile(recs / "run_000000.txt");
    for (const char* gone : {"run_000002.txt", "run_000005.txt", "run_000007.txt"}) fs::remove(recs / gone);
    fs::remove(d / "out" / "sweep.csv");
    fs::remove(d / "out" / "sweep-summary.csv");
    const Result r = runMpi(d, 3, sweepArgs(d / "out", kGrid));
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(count(r.err, "5 runs of 8 already finished, 3 to run") == 1u, r.err);
    BOOST_TEST(r.out.find("(5 already done, 3 run now") != std::string::npos, r.out);
    BOOST_TEST(readFile(recs / "run_000000.txt") == kept);
    BOOST_TEST(records(d / "out") == 8u);
    BOOST_TEST(withoutWallTime(readFile(d / "out" / "sweep.csv")) == withoutWallTime(readFile(localGrid() / "sweep.csv")));
    BOOST_TEST(readFile(d / "out" / "sweep-summary.csv") == readFile(localGrid() / "sweep-summary.csv"));
}

BOOST_AUTO_TEST_CASE(a_killed_mpi_sweep_resumes_to_the_same_files) {
    const fs::path d = freshDir(caseName());
    // 40 runs of about 0.3 s each (mpirun takes a second or two to pass the signal on).
    const std::vector<std::string> args = {"--vary", "agents.pref_speed=1:1.9:0.1", "--replications", "4", "--quiet"};
    const Result whole = run(d, sweepArgs(d / "whole", args));
    BOOST_REQUIRE_MESSAGE(whole.status == 0, whole.err);
    {  // SIGTERM to mpirun (as Ctrl-C or scancel would) once a few runs are recorded
        MpiBackground b(d, mpiArgs(3, sweepArgs(d / "out", args)));
        BOOST_REQUIRE(waitFor([&] { return records(d / "out") >= 2; }, 120));
        b.signal(SIGTERM);
        const int status = b.wait();
        BOOST_TEST(status != 0, "mpirun exit status " << status);
    }
    const std::size_t afterKill = records(d / "out");
    BOOST_TEST_REQUIRE(afterKill < 40u);
    BOOST_TEST(!fs::exists(d / "out" / "sweep.csv"));
    {  // SIGTERM to rank 0 alone: it hands out no more runs, records the two going, stops the workers
        MpiBackground b(d, mpiArgs(3, sweepArgs(d / "out", args)));
        BOOST_REQUIRE(waitFor([&] { return records(d / "out") >= afterKill + 2; }, 120));
        const pid_t controller = b.rankPid(0);
        BOOST_REQUIRE(controller > 0);
        ::kill(controller, SIGTERM);
        BOOST_TEST(b.wait() == 130);  // every rank exits 130
        BOOST_TEST(count(readFile(d / "_stderr.txt"), "run the same command again") == 1u, readFile(d / "_stderr.txt"));
    }
    BOOST_TEST_REQUIRE(records(d / "out") < 40u);
    BOOST_TEST(!fs::exists(d / "out" / "sweep.csv"));
    const Result resumed = runMpi(d, 3, sweepArgs(d / "out", args));
    BOOST_REQUIRE_MESSAGE(resumed.status == 0, resumed.err);
    BOOST_TEST(records(d / "out") == 40u);
    BOOST_TEST(withoutWallTime(readFile(d / "out" / "sweep.csv")) == withoutWallTime(readFile(d / "whole" / "sweep.csv")));
    BOOST_TEST(readFile(d / "out" / "sweep-summary.csv") == readFile(d / "whole" / "sweep-summary.csv"));
    BOOST_TEST(tmpFiles(d / "out").empty());
}

BOOST_AUTO_TEST_CASE(errors_are_printed_once_and_every_rank_exits_2) {
    const fs::path d = freshDir(caseName());
    // A bad value: found by every rank in the arguments.
    const MpiResult bad = runMpi(d, 3, sweepArgs(d / "out", {"--vary", "agents.pref_speed=1,abc"}));
    BOOST_TEST(bad.status == 2);
    BOOST_TEST(allRanksExited(runMpi(d, 3, sweepArgs(d / "out", {"--vary", "agents.pref_speed=1,abc"}), true), 2));
    BOOST_TEST(count(bad.err, "crowdhealth: error: --vary 'agents.pref_speed=1,abc'") == 1u, bad.err);
    BOOST_TEST(!fs::exists(d / "out"));
    // A bad target: found when the scenario is loaded.
    const MpiResult target = runMpi(d, 3, sweepArgs(d / "out", {"--vary", "7.SPH.restDensityMax=3"}));
    BOOST_TEST(target.status == 2);
    BOOST_TEST(allRanksExited(runMpi(d, 3, sweepArgs(d / "out", {"--vary", "7.SPH.restDensityMax=3"}), true), 2));
    BOOST_TEST(count(target.err, "policy 7 does not exist") == 1u, target.err);
    // OUTDIR not empty and no sweep there: only rank 0 looks at OUTDIR; the others must not wait for it.
    fs::create_directories(d / "full");
    std::ofstream(d / "full" / "something.txt") << "x\n";
    const MpiResult full = runMpi(d, 3, sweepArgs(d / "full", {"--vary", "agents.pref_speed=1"}));
    BOOST_TEST(full.status == 2);
    BOOST_TEST(allRanksExited(runMpi(d, 3, sweepArgs(d / "full", {"--vary", "agents.pref_speed=1"}), true), 2));
    BOOST_TEST(count(full.err, "holds no sweep") == 1u, full.err);
    // --help: printed once.
    const MpiResult help = runMpi(d, 3, {"sweep", "--help"});
    BOOST_TEST(help.status == 0);
    BOOST_TEST(allRanksExited(runMpi(d, 3, {"sweep", "--help"}, true), 0));
    BOOST_TEST(count(help.out, "Usage: crowdhealth sweep") == 1u, help.out);
}

// ---- crowdhealth calibrate on the same machinery ----

namespace {

/// A calibration of the door template (Tests/data/cli/calibrate-door.xml) against two made-up
/// evacuation times: 2 conditions × 2 seeds per evaluation.
std::vector<std::string> calibrateArgs(const fs::path& dir, const fs::path& out, const std::vector<std::string>& more = {}) {
    writeText(dir / "door.csv", "width,evacuation_time\n1.8,9.4\n2,8.6\n");
    std::vector<std::string> a = {"calibrate", "-i", testData("calibrate-door.xml"), "--data", (dir / "door.csv").string(),
                                  "--fit", "agents.pref_speed=0.7:1.6", "--seeds", "2", "--seed", "3",
                                  "--max-evaluations", "12", "-o", out.string()};
    a.insert(a.end(), more.begin(), more.end());
    return a;
}

}  // namespace

BOOST_AUTO_TEST_CASE(a_calibration_under_mpi_gives_the_same_search_and_result) {
    const fs::path d = freshDir(caseName());
    const Result local = run(d, calibrateArgs(d, d / "local", {"--quiet"}));
    BOOST_REQUIRE_MESSAGE(local.status == 0, local.err);
    const MpiResult m = runMpi(d, 3, calibrateArgs(d, d / "mpi"));
    BOOST_REQUIRE_MESSAGE(m.status == 0, m.err);
    BOOST_TEST(readFile(d / "mpi" / "calibration.csv") == readFile(d / "local" / "calibration.csv"));
    BOOST_TEST(readFile(d / "mpi" / "calibration-result.json") == readFile(d / "local" / "calibration-result.json"));
    BOOST_TEST(lines(readFile(d / "local" / "calibration.csv")).size() > 10u);  // a search, not one point
    BOOST_TEST(count(m.out, "crowdhealth calibrate:") == 1u, m.out);  // one closing report, from rank 0
}

BOOST_AUTO_TEST_CASE(calibration_errors_are_printed_once_and_every_rank_exits_2) {
    const fs::path d = freshDir(caseName());
    auto a = calibrateArgs(d, d / "out");
    a[4] = (d / "missing.csv").string();  // --data FILE that no rank can read
    const MpiResult bad = runMpi(d, 3, a);
    BOOST_TEST(bad.status == 2);
    BOOST_TEST(count(bad.err, "cannot read the data file") == 1u, bad.err);
    BOOST_TEST(allRanksExited(runMpi(d, 3, a, true), 2));
    BOOST_TEST(!fs::exists(d / "out"));
    // A file only the controller cannot write to: the workers must not wait for it.
    std::ofstream(d / "blocked") << "a file, not a folder\n";
    const auto blocked = calibrateArgs(d, d / "blocked" / "out");
    BOOST_TEST(allRanksExited(runMpi(d, 3, blocked, true), 1));
}
