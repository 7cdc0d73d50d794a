// crowdhealth — the command-line program: run a scenario, check it, or list the components.
// Usage: see `crowdhealth --help` (cli.cpp). Exit statuses: exit_codes.h.
#include "calibrate.h"
#include "cli.h"
#include "compare.h"
#include "exit_codes.h"
#include "list_policies.h"
#include "plot.h"
#include "render.h"
#include "run.h"
#include "sweep.h"
#include "verify.h"

#include <exception>
#include <iostream>
#include <string_view>

int main(int argc, char* argv[]) {
    using namespace chcli;
    try {
        // `crowdhealth render …` has its own options (render.h, docs/rendering.md).
        if (argc > 1 && std::string_view(argv[1]) == "render") return renderCommand(argc - 1, argv + 1);
        // `crowdhealth plot DIR` and `crowdhealth compare DIR…` too (plot.h, compare.h, docs/crowd-health.md).
        if (argc > 1 && std::string_view(argv[1]) == "plot") return plotCommand(argc - 1, argv + 1);
        if (argc > 1 && std::string_view(argv[1]) == "compare") return compareCommand(argc - 1, argv + 1);
        // `crowdhealth verify …`: the verification tests for every model (verify.h, docs/verification.md).
        if (argc > 1 && std::string_view(argv[1]) == "verify") return verifyCommand(argc - 1, argv + 1);
        // `crowdhealth sweep …`: parameter studies (sweep.h, docs/sweeps.md).
        if (argc > 1 && std::string_view(argv[1]) == "sweep") return sweepCommand(argc - 1, argv + 1);
        // `crowdhealth calibrate …`: fitting parameters to experimental data (calibrate.h, docs/sweeps.md).
        if (argc > 1 && std::string_view(argv[1]) == "calibrate") return calibrateCommand(argc - 1, argv + 1);
        const std::optional<Options> options = parseCommandLine(argc, argv, std::cerr);
        if (!options) return kExitInput;
        if (!loadPlugins(options->plugins, std::cerr)) return kExitInput;
        switch (options->command) {
            case Command::Help: printHelp(std::cout); return kExitOk;
            case Command::Version: printVersion(std::cout); return kExitOk;
            case Command::ListPolicies: printComponents(std::cout, options->format); return kExitOk;
            case Command::Check: return checkScenario(*options);
            case Command::Run: return runScenario(*options);
        }
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth: internal error: " << e.what() << "\n";
    }
    return kExitRuntime;
}
