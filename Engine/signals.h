// crowdhealth — Ctrl-C handling: SIGINT/SIGTERM only set a flag; the run loop checks it after
// every coarse step, stops, and still writes complete outputs for the time simulated.
#pragma once

namespace chcli {

/// Installs the handlers for SIGINT and SIGTERM. A second signal of the same kind is not caught
/// (the handler is one-shot), so pressing Ctrl-C twice kills a program stuck in a long step.
void installInterruptHandlers();
/// True once SIGINT or SIGTERM has arrived.
bool interruptRequested();
/// The signal that arrived (0 if none).
int interruptSignal();

}  // namespace chcli
