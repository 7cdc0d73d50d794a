// crowdhealth verify — the verification tests (RiMEA, ISO 20414 / NIST TN 1822) for every model:
//
//   crowdhealth verify [-o DIR] [--quick] [--policy NAME ...] [--test ID ...] [--jobs N]
//                      [--tests-dir DIR] [-q]
//
// Each test is a scenario file in Examples/verification/ that also runs on its own with
// `crowdhealth -i` (with its own policy, id 0: UMANS' social forces). For each model M, verify
// loads Examples/verification/models/M.xml with the normal loader and puts its policy id 0 in
// place of the test's policy id 0 (the only policy every test has), then runs the test over its
// seeds and applies the test's criterion (verify_criteria.h). Writes DIR/report.md (a matrix
// test × model: pass / fail / documented / out of scope / pending, the measured value, the
// criterion, what a failure means) and DIR/verify.csv. Exit status 0 iff every test with a pass
// criterion passes for every model it is claimed for; 1 when one fails (or a run fails); 2 for a
// bad command line or a test or model file that does not load. docs/verification.md.
#pragma once

namespace chcli {

/// Runs the `verify` subcommand; argv[0] is "verify".
int verifyCommand(int argc, char* argv[]);

}  // namespace chcli
