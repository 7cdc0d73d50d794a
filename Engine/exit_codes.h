// crowdhealth — the program's exit statuses (documented in --help).
#pragma once

namespace chcli {

inline constexpr int kExitOk = 0;
/// A runtime failure: the output folder cannot be created or written, or the run failed.
inline constexpr int kExitRuntime = 1;
/// Bad input: command-line usage or scenario errors. Nothing was simulated or written.
inline constexpr int kExitInput = 2;
/// Stopped by SIGINT/SIGTERM (128 + SIGINT, the shell's convention for Ctrl-C); the outputs
/// cover the time simulated.
inline constexpr int kExitInterrupted = 130;

}  // namespace chcli
