// crowdhealth — the command-line program: run a scenario, check it, or list the components.
// Usage: see `crowdhealth --help` (cli.cpp). Exit statuses: exit_codes.h.
#include "cli.h"
#include "exit_codes.h"
#include "list_policies.h"
#include "run.h"

#include <exception>
#include <iostream>

int main(int argc, char* argv[]) {
    using namespace chcli;
    try {
        const std::optional<Options> options = parseCommandLine(argc, argv, std::cerr);
        if (!options) return kExitInput;
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
