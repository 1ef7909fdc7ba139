// The named scenes. World z-up, metres; every scene's start pose is a level body at x = 0
// (or near) looking along +x, and the interesting geometry lies ahead of it.
#include "kestrel/sim/scenes.hpp"

#include <memory>
#include <string>

#include "kestrel/core/error.hpp"

namespace kestrel::sim {

namespace {

const std::vector<CatalogueEntry> kScenes = {
    {"office",
     "6 x 5 x 2.8 m room: textured walls with posters, carpet, a desk with a "
     "monitor, a cabinet and a crate; a ceiling light (good for odometry)"},
    {"corridor",
     "30 m corridor, 2 m wide, with nearly textureless walls (+-1.5 % contrast), "
     "doors and skirting boards; three ceiling lights"},
    {"bare_corridor",
     "the corridor without doors or skirting: walls, floor and ceiling of nearly uniform "
     "paint (+-1.5 % contrast); three ceiling lights"},
    {"wall",
     "a plain low-texture wall 3 m ahead with a textured box before it (the thesis' "
     "passive vs active stereo experiment, fig. 2.7)"},
    {"checker",
     "checkerboard ground plane (infinite), a checkerboard wall 4 m ahead and two "
     "boxes: simple high-texture test scene"},
};

using TexturePtr = std::shared_ptr<const Texture>;

TexturePtr share(Texture t) { return std::make_shared<const Texture>(std::move(t)); }

Material material(TexturePtr texture, const ColorBgr& albedo = {1.0F, 1.0F, 1.0F}) {
  return Material{std::move(texture), albedo};
}

/// Seed of texture number `k` of a scene, decorrelated from the scene's texture seed.
std::uint64_t tex_seed(std::uint64_t scene_seed, std::uint64_t k) {
  return scene_seed * 7919ULL + k * 104729ULL + 17ULL;
}

PlanarRect rect(const Eigen::Vector3d& origin, const Eigen::Vector3d& s_dir,
                const Eigen::Vector3d& t_dir, double w, double h, Material m) {
  return PlanarRect::from_corner(origin, s_dir, t_dir, w, h, std::move(m));
}

OrientedBox box(const Eigen::Vector3d& centre, const Eigen::Vector3d& half, Material m,
                double yaw_rad = 0.0) {
  return OrientedBox{SE3(SO3::exp(Eigen::Vector3d(0, 0, yaw_rad)), centre), half, std::move(m)};
}

SE3 start_at(double x, double y, double z) { return SE3(SO3(), Eigen::Vector3d(x, y, z)); }

const Eigen::Vector3d kX = Eigen::Vector3d::UnitX();
const Eigen::Vector3d kY = Eigen::Vector3d::UnitY();
const Eigen::Vector3d kZ = Eigen::Vector3d::UnitZ();

Scene make_office(std::uint64_t seed) {
  Scene scene("office", std::string(kScenes[0].description));
  // Room x in [-3, 3], y in [-2.5, 2.5], z in [0, 2.8]; normals point into the room.
  ValueNoiseOptions carpet;
  carpet.base_cells = 32;
  carpet.texel_size_m = 0.006;
  carpet.dark = {0.16F, 0.22F, 0.32F};
  carpet.bright = {0.36F, 0.46F, 0.58F};
  BlobTextureOptions posters;
  posters.count = 140;
  BlobTextureOptions marks = posters;
  marks.count = 220;
  marks.max_radius_px = 18.0;
  marks.base = {0.62F, 0.72F, 0.78F};
  ValueNoiseOptions wallpaper;
  wallpaper.base_cells = 16;
  wallpaper.dark = {0.45F, 0.55F, 0.58F};
  wallpaper.bright = {0.82F, 0.86F, 0.88F};
  ValueNoiseOptions wood;
  wood.size_px = 256;
  wood.texel_size_m = 0.005;
  wood.base_cells = 16;
  wood.dark = {0.12F, 0.25F, 0.40F};
  wood.bright = {0.30F, 0.50F, 0.70F};
  ValueNoiseOptions dark_plastic = wood;
  dark_plastic.base_cells = 8;
  dark_plastic.dark = {0.06F, 0.06F, 0.07F};
  dark_plastic.bright = {0.30F, 0.30F, 0.33F};
  BlobTextureOptions crate = posters;
  crate.size_px = 256;
  crate.texel_size_m = 0.004;
  crate.count = 60;
  crate.base = {0.35F, 0.55F, 0.6F};

  const auto floor_tex = share(make_value_noise_texture(carpet, tex_seed(seed, 1)));
  const auto front_tex = share(make_blob_texture(posters, tex_seed(seed, 2)));
  const auto back_tex = share(make_blob_texture(marks, tex_seed(seed, 3)));
  const auto side_tex = share(make_value_noise_texture(wallpaper, tex_seed(seed, 4)));
  const auto ceiling_tex =
      share(make_low_contrast_texture({0.85F, 0.87F, 0.88F}, 0.02, tex_seed(seed, 5)));
  const auto wood_tex = share(make_value_noise_texture(wood, tex_seed(seed, 6)));
  const auto plastic_tex = share(make_value_noise_texture(dark_plastic, tex_seed(seed, 7)));
  const auto crate_tex = share(make_blob_texture(crate, tex_seed(seed, 8)));
  const auto checker_tex =
      share(make_checkerboard_texture(0.1, {0.1F, 0.1F, 0.1F}, {0.9F, 0.9F, 0.9F}));

  scene.add(rect({-3, -2.5, 0}, kX, kY, 6.0, 5.0, material(floor_tex)));
  scene.add(rect({-3, 2.5, 2.8}, kX, -kY, 6.0, 5.0, material(ceiling_tex)));
  scene.add(rect({3, 2.5, 0}, -kY, kZ, 5.0, 2.8, material(front_tex)));
  scene.add(rect({-3, -2.5, 0}, kY, kZ, 5.0, 2.8, material(back_tex)));
  scene.add(rect({-3, 2.5, 0}, kX, kZ, 6.0, 2.8, material(side_tex)));
  scene.add(rect({3, -2.5, 0}, -kX, kZ, 6.0, 2.8, material(side_tex, {0.95F, 0.9F, 1.0F})));
  // Posters a few millimetres before the side walls.
  scene.add(rect({0.2, 2.495, 1.0}, kX, kZ, 1.2, 0.8, material(front_tex, {1.0F, 0.9F, 0.8F})));
  scene.add(rect({1.4, -2.495, 0.9}, -kX, kZ, 0.8, 0.8, material(checker_tex)));
  // Desk with a monitor, a cabinet, a crate.
  scene.add(box({1.9, 0.2, 0.375}, {0.4, 0.75, 0.375}, material(wood_tex)));
  scene.add(box({2.1, 0.3, 0.95}, {0.04, 0.3, 0.2}, material(plastic_tex)));
  scene.add(box({2.45, -1.95, 0.6}, {0.3, 0.4, 0.6}, material(wood_tex, {0.8F, 0.9F, 1.0F})));
  scene.add(box({0.9, 1.6, 0.25}, {0.25, 0.3, 0.25}, material(crate_tex), 0.4));

  scene.set_ambient(0.5F);
  scene.add_light(std::make_shared<PointLight>(Eigen::Vector3d(0.0, 0.0, 2.6),
                                               ColorBgr(0.55F, 0.6F, 0.6F), 3.0));
  scene.set_T_world_start(start_at(-0.5, 0.0, 1.2));
  return scene;
}

// Corridor x in [-5, 25], y in [-1, 1], z in [0, 2.6]: floor, ceiling, walls and three
// ceiling lights; the floor's texture contrast is the caller's.
constexpr double kCorridorX0 = -5.0, kCorridorLength = 30.0, kCorridorHalfWidth = 1.0,
                 kCorridorHeight = 2.6;

void add_corridor_shell(Scene& scene, std::uint64_t seed, double floor_contrast) {
  constexpr double x0 = kCorridorX0, length = kCorridorLength, half_width = kCorridorHalfWidth,
                   height = kCorridorHeight;
  const auto wall_tex =
      share(make_low_contrast_texture({0.74F, 0.76F, 0.78F}, 0.015, tex_seed(seed, 1)));
  const auto floor_tex =
      share(make_low_contrast_texture({0.52F, 0.50F, 0.46F}, floor_contrast, tex_seed(seed, 2)));
  const auto ceiling_tex =
      share(make_low_contrast_texture({0.86F, 0.86F, 0.86F}, 0.01, tex_seed(seed, 3)));
  scene.add(rect({x0, -half_width, 0}, kX, kY, length, 2 * half_width, material(floor_tex)));
  scene.add(rect({x0, half_width, height}, kX, -kY, length, 2 * half_width, material(ceiling_tex)));
  scene.add(rect({x0, half_width, 0}, kX, kZ, length, height, material(wall_tex)));
  scene.add(rect({x0 + length, -half_width, 0}, -kX, kZ, length, height, material(wall_tex)));
  scene.add(
      rect({x0 + length, half_width, 0}, -kY, kZ, 2 * half_width, height, material(wall_tex)));
  scene.add(rect({x0, -half_width, 0}, kY, kZ, 2 * half_width, height, material(wall_tex)));
  scene.set_ambient(0.45F);
  for (const double x : {0.0, 8.0, 16.0}) {
    scene.add_light(std::make_shared<PointLight>(Eigen::Vector3d(x, 0.0, 2.5),
                                                 ColorBgr(0.5F, 0.5F, 0.5F), 3.0));
  }
  scene.set_T_world_start(start_at(0.0, 0.0, 1.2));
}

Scene make_corridor(std::uint64_t seed) {
  Scene scene("corridor", std::string(kScenes[1].description));
  add_corridor_shell(scene, seed, 0.04);
  constexpr double x0 = kCorridorX0, length = kCorridorLength, half_width = kCorridorHalfWidth;
  const auto door_tex =
      share(make_low_contrast_texture({0.30F, 0.42F, 0.55F}, 0.03, tex_seed(seed, 4)));
  const auto skirting_tex = share(Texture::constant({0.35F, 0.35F, 0.36F}));
  // Skirting boards and doors, 5 mm before the walls.
  constexpr double inset = 0.005;
  scene.add(rect({x0, half_width - inset, 0}, kX, kZ, length, 0.1, material(skirting_tex)));
  scene.add(
      rect({x0 + length, -half_width + inset, 0}, -kX, kZ, length, 0.1, material(skirting_tex)));
  for (int i = 0; i < 5; ++i) {
    const double x = 2.0 + 5.0 * i;
    if (i % 2 == 0) {
      scene.add(rect({x, half_width - 2 * inset, 0}, kX, kZ, 0.9, 2.05, material(door_tex)));
    } else {
      scene.add(
          rect({x + 0.9, -half_width + 2 * inset, 0}, -kX, kZ, 0.9, 2.05, material(door_tex)));
    }
  }
  return scene;
}

// The corridor without doors or skirting, the floor as plain as the walls.
Scene make_bare_corridor(std::uint64_t seed) {
  Scene scene("bare_corridor", std::string(kScenes[2].description));
  add_corridor_shell(scene, seed, 0.015);
  return scene;
}

Scene make_wall(std::uint64_t seed) {
  Scene scene("wall", std::string(kScenes[3].description));
  const auto wall_tex =
      share(make_low_contrast_texture({0.78F, 0.80F, 0.80F}, 0.01, tex_seed(seed, 1)));
  const auto floor_tex =
      share(make_low_contrast_texture({0.45F, 0.45F, 0.47F}, 0.03, tex_seed(seed, 2)));
  ValueNoiseOptions box_noise;
  box_noise.size_px = 256;
  box_noise.texel_size_m = 0.005;
  box_noise.base_cells = 16;
  box_noise.dark = {0.15F, 0.25F, 0.45F};
  box_noise.bright = {0.55F, 0.70F, 0.85F};
  const auto box_tex = share(make_value_noise_texture(box_noise, tex_seed(seed, 3)));

  scene.add(rect({3.0, 3.0, 0}, -kY, kZ, 6.0, 3.0, material(wall_tex)));
  scene.add(rect({-2.0, -3.0, 0}, kX, kY, 5.0, 6.0, material(floor_tex)));
  scene.add(box({2.0, 0.4, 0.6}, {0.3, 0.3, 0.6}, material(box_tex), 0.3));
  scene.set_ambient(0.55F);
  scene.add_light(std::make_shared<PointLight>(Eigen::Vector3d(0.0, 0.0, 2.5),
                                               ColorBgr(0.45F, 0.45F, 0.45F), 4.0));
  scene.set_T_world_start(start_at(0.0, 0.0, 1.0));
  return scene;
}

Scene make_checker(std::uint64_t seed) {
  Scene scene("checker", std::string(kScenes[4].description));
  const auto ground_tex =
      share(make_checkerboard_texture(0.25, {0.15F, 0.15F, 0.15F}, {0.85F, 0.85F, 0.85F}));
  const auto wall_tex =
      share(make_checkerboard_texture(0.2, {0.2F, 0.3F, 0.7F}, {0.9F, 0.85F, 0.8F}));
  const auto small_tex =
      share(make_checkerboard_texture(0.1, {0.1F, 0.6F, 0.2F}, {0.9F, 0.9F, 0.9F}));
  ValueNoiseOptions noise;
  noise.size_px = 256;
  noise.texel_size_m = 0.004;
  noise.base_cells = 8;
  noise.dark = {0.1F, 0.1F, 0.4F};
  noise.bright = {0.7F, 0.9F, 0.9F};
  const auto noise_tex = share(make_value_noise_texture(noise, tex_seed(seed, 1)));

  scene.add(InfinitePlane{SE3(), material(ground_tex)});
  scene.add(rect({4.0, 4.0, 0}, -kY, kZ, 8.0, 3.0, material(wall_tex)));
  scene.add(box({2.0, -0.8, 0.3}, {0.3, 0.3, 0.3}, material(noise_tex), 0.5));
  scene.add(box({2.8, 0.9, 0.5}, {0.25, 0.25, 0.5}, material(small_tex), -0.3));
  scene.set_ambient(0.6F);
  scene.add_light(std::make_shared<DirectionalLight>(Eigen::Vector3d(0.3, 0.2, -1.0),
                                                     ColorBgr(0.4F, 0.4F, 0.4F)));
  scene.set_T_world_start(start_at(0.0, 0.0, 1.2));
  return scene;
}

}  // namespace

const std::vector<CatalogueEntry>& scene_catalogue() { return kScenes; }

Scene make_scene(std::string_view name, std::uint64_t texture_seed) {
  if (name == "office") return make_office(texture_seed);
  if (name == "corridor") return make_corridor(texture_seed);
  if (name == "bare_corridor") return make_bare_corridor(texture_seed);
  if (name == "wall") return make_wall(texture_seed);
  if (name == "checker") return make_checker(texture_seed);
  throw InputError("unknown scene '" + std::string(name) + "' (valid: " + catalogue_names(kScenes) +
                   ")");
}

}  // namespace kestrel::sim
