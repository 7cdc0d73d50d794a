// crowdhealth --list-policies: every registered cost function and force with its parameter
// table, as aligned text or as Markdown (which generates parts of docs/xml-reference).
#pragma once

#include "cli.h"

#include <iosfwd>

namespace chcli {

/// Prints every component of ch::Registry::instance(), sorted by name.
void printComponents(std::ostream& out, ListFormat format);

}  // namespace chcli
