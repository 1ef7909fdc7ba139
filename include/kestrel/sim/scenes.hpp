// The named synthetic scenes (z-up world, metres): "office", "corridor", "wall", "checker".
// Each comes with a start pose for the body, looking horizontally along world +x.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

#include "kestrel/sim/catalogue.hpp"
#include "kestrel/sim/scene.hpp"

namespace kestrel::sim {

/// The named scenes with their descriptions.
const std::vector<CatalogueEntry>& scene_catalogue();

/// Builds a named scene. Textures come from `texture_seed` (0: the canonical scene; other
/// values give the same geometry with other random textures). Throws InputError naming the
/// valid scenes for an unknown name.
Scene make_scene(std::string_view name, std::uint64_t texture_seed = 0);

}  // namespace kestrel::sim
