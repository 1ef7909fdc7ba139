// Named things the simulator can build (scenes, trajectories), with one-line descriptions for
// `kestrel render --list` and for error messages that list the valid names.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace kestrel::sim {

struct CatalogueEntry {
  std::string_view name;
  std::string_view description;
};

/// "a, b, c": the names of a catalogue, for error messages.
std::string catalogue_names(const std::vector<CatalogueEntry>& catalogue);

}  // namespace kestrel::sim
