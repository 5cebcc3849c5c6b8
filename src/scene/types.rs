//! The in-memory scene model: what the loader produces and the renderer consumes.
//!
//! Units: positions in scene units (the shipped scenes use metres); colours are linear RGB;
//! see the README's scene-format section for the light units.

use glam::{Mat4, Vec2, Vec3};
use std::path::PathBuf;

/// A loaded, validated scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The scene file this came from (for messages).
    pub path: PathBuf,
    pub name: String,
    /// Geometry in object space. Each mesh has exactly one material.
    pub meshes: Vec<Mesh>,
    /// Instances of meshes with a transform; every mesh belongs to exactly one object.
    pub objects: Vec<Object>,
    pub materials: Vec<Material>,
    /// Decoded textures, referenced by `Material::albedo_texture`.
    pub textures: Vec<Texture>,
    pub camera: Camera,
    pub lights: Vec<Light>,
    /// What rays that leave the scene see (`[sky]`); `None`: black.
    pub sky: Option<super::Sky>,
    pub settings: RenderSettings,
    /// Bounds given by the scene file (used by the voxel grid); `None` means "fit to geometry".
    pub bounds: Option<Aabb>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
    /// The box of the eight transformed corners.
    pub fn transformed(&self, m: &Mat4) -> Aabb {
        let mut out = Aabb::EMPTY;
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            out.grow(m.transform_point3(c));
        }
        out
    }
}

/// Triangle mesh in object space. `normals` and `uvs` have one entry per position
/// (the loader generates flat/smooth normals where the file has none, and zero UVs).
#[derive(Debug, Clone)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    /// Triangle list.
    pub indices: Vec<u32>,
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Object-space bounds of `positions`.
    pub bounds: Aabb,
}

#[derive(Debug, Clone)]
pub struct Object {
    pub name: String,
    /// Indices into `Scene::meshes`.
    pub meshes: Vec<u32>,
    /// Static placement (applied before motion).
    pub transform: Mat4,
    /// Dynamic objects are re-voxelized when they move; static ones are voxelized once.
    pub dynamic: bool,
    pub motion: Motion,
}

impl Object {
    /// Object-to-world matrix at time `t` seconds.
    pub fn model_matrix(&self, t: f32) -> Mat4 {
        self.motion.matrix(t) * self.transform
    }
}

/// Motion over time, as a world-space matrix applied after the static transform.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum Motion {
    #[default]
    None,
    /// Parametric: rotation about `axis` through `pivot` at `degrees_per_second`, then a
    /// translation of `velocity * t + amplitude * sin(2*pi*t/period)`.
    Parametric { axis: Vec3, pivot: Vec3, degrees_per_second: f32, velocity: Vec3, amplitude: Vec3, period: f32 },
    /// Keyframes sorted by time, linearly interpolated (rotation by slerp), clamped at the ends.
    Keyframes(Vec<Keyframe>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Keyframe {
    pub time: f32,
    pub translate: Vec3,
    /// Rotation in degrees about X, then Y, then Z.
    pub rotate_deg: Vec3,
    pub scale: Vec3,
}

impl Motion {
    pub fn is_static(&self) -> bool {
        matches!(self, Motion::None)
    }
    /// World-space matrix at time `t` (seconds).
    pub fn matrix(&self, t: f32) -> Mat4 {
        match self {
            Motion::None => Mat4::IDENTITY,
            Motion::Parametric { axis, pivot, degrees_per_second, velocity, amplitude, period } => {
                let rot = if axis.length_squared() > 0.0 && *degrees_per_second != 0.0 {
                    Mat4::from_translation(*pivot)
                        * Mat4::from_axis_angle(axis.normalize(), (degrees_per_second * t).to_radians())
                        * Mat4::from_translation(-*pivot)
                } else {
                    Mat4::IDENTITY
                };
                let osc =
                    if *period > 0.0 { *amplitude * (std::f32::consts::TAU * t / period).sin() } else { Vec3::ZERO };
                Mat4::from_translation(*velocity * t + osc) * rot
            }
            Motion::Keyframes(keys) => {
                let Some(first) = keys.first() else {
                    return Mat4::IDENTITY;
                };
                let key_at = |k: &Keyframe| (k.translate, euler_quat(k.rotate_deg), k.scale);
                let (tr, rot, sc) = if t <= first.time || keys.len() == 1 {
                    key_at(first)
                } else if let Some(i) = keys.windows(2).position(|w| t < w[1].time) {
                    let (a, b) = (&keys[i], &keys[i + 1]);
                    let span = (b.time - a.time).max(f32::MIN_POSITIVE);
                    let f = ((t - a.time) / span).clamp(0.0, 1.0);
                    let (ta, ra, sa) = key_at(a);
                    let (tb, rb, sb) = key_at(b);
                    (ta.lerp(tb, f), ra.slerp(rb, f), sa.lerp(sb, f))
                } else {
                    key_at(keys.last().unwrap())
                };
                Mat4::from_scale_rotation_translation(sc, rot, tr)
            }
        }
    }
}

/// Rotation from degrees about X, then Y, then Z (applied in that order to a point).
pub fn euler_quat(deg: Vec3) -> glam::Quat {
    let r = deg * (std::f32::consts::PI / 180.0);
    glam::Quat::from_euler(glam::EulerRot::ZYX, r.z, r.y, r.x)
}

/// Lambert + energy-normalised Blinn-Phong material. All colours linear.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: String,
    /// Diffuse albedo (reflectance in [0,1]); the BRDF is albedo/pi.
    pub albedo: Vec3,
    /// Multiplies `albedo` when present (texture is sRGB-encoded, decoded to linear on sampling).
    pub albedo_texture: Option<u32>,
    /// Alpha-test cutout (`map_d`): a `TextureUse::Mask` texture; the surface exists where its
    /// coverage is at least [`MASK_CUTOFF`], in the G-buffer, shadow maps, voxels and path tracer.
    pub mask_texture: Option<u32>,
    /// Normal perturbation, in the G-buffer and the path tracer alike: a tangent-space normal
    /// map (`TextureUse::Normal`) or a height map (`TextureUse::Height`).
    pub normal_texture: Option<u32>,
    /// How deep a height map's relief is: by default [`DEFAULT_RELIEF`] of the texture's tile
    /// per unit of height, whatever the scene's unit.
    pub relief: Relief,
    /// Specular reflectance Ks; the lobe is Ks * (n+8)/(8 pi) * (N.H)^n.
    pub specular: Vec3,
    /// Blinn-Phong exponent n (Ns), >= 0.
    pub shininess: f32,
    /// Emitted radiance, W/(sr m^2) per channel.
    pub emission: Vec3,
}

impl Material {
    /// A plain Lambertian material: no textures, no specular, no emission.
    pub fn diffuse(name: &str, albedo: Vec3) -> Material {
        Material {
            name: name.to_owned(),
            albedo,
            albedo_texture: None,
            mask_texture: None,
            normal_texture: None,
            relief: Relief::default(),
            specular: Vec3::ZERO,
            shininess: 1.0,
            emission: Vec3::ZERO,
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
    pub fn is_glossy(&self) -> bool {
        self.specular.max_element() > 0.0
    }
}

/// A height map's relief per unit of height, in the texture's own space: this fraction of one
/// tile (one unit of UV). A 0..1 map is a relief of 1% of its tile whatever the scene's unit
/// and the map's resolution, so the same stone reads the same in a scene in metres or in
/// centimetres (issue 42: one metre per unit height, the old default, made a cathedral in
/// metres 29% darker than without its maps). scenes/FORMAT.md says how it was chosen.
pub const DEFAULT_RELIEF: f32 = 0.01;

/// How deep a height map's relief is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Relief {
    /// `m` times [`DEFAULT_RELIEF`] (texture space): the MTL's `-bm m` (the spec's "bump
    /// multiplier", which multiplies the map's values), the scene file's `bump_relief`.
    Tile(f32),
    /// Scene units per unit of height (pbrt's and Mitsuba's bump mapping): `bump_scale`.
    Units(f32),
}

impl Default for Relief {
    fn default() -> Self {
        Relief::Tile(1.0)
    }
}

impl Relief {
    pub fn value(self) -> f32 {
        match self {
            Relief::Tile(v) | Relief::Units(v) => v,
        }
    }
}

/// Coverage at or above which an alpha-masked surface is opaque.
pub const MASK_CUTOFF: f32 = 0.5;

/// What a texture holds, which decides its encoding and how its mip chain is filtered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum TextureUse {
    /// sRGB-encoded colour (alpha linear); mips average in linear light.
    #[default]
    Color,
    /// Coverage in every channel, linear; mips keep the fraction of texels at or above
    /// [`MASK_CUTOFF`] (so cutouts do not thin out or vanish with distance).
    Mask,
    /// Tangent-space unit normal, each component c stored as (c + 1) / 2, linear. OpenGL
    /// convention: +x along +u, +y along +v of the OBJ's UVs (up in the image), +z outwards.
    Normal,
    /// Height in [0, 1] in every channel, linear. Uploaded as the tangent-space normal map of
    /// the surface displaced [`DEFAULT_RELIEF`] tiles per unit of height (`scene::maps`);
    /// `Material::relief` scales it.
    Height,
}

/// RGBA8 texels, row-major, top row first, encoded as `usage` says.
#[derive(Debug, Clone)]
pub struct Texture {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    pub rgba8: Vec<u8>,
    pub usage: TextureUse,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y_deg: f32,
    pub near: f32,
    pub far: f32,
}

impl Camera {
    pub fn view(&self) -> Mat4 {
        Mat4::look_at_rh(self.position, self.target, self.up)
    }
    /// Vulkan clip space (y down, depth 0..1).
    pub fn projection(&self, aspect: f32) -> Mat4 {
        let mut p = Mat4::perspective_rh(self.fov_y_deg.to_radians(), aspect, self.near, self.far);
        p.y_axis.y = -p.y_axis.y;
        p
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum LightKind {
    /// `direction` is the direction the light travels (from the light towards the scene),
    /// `irradiance` in W/m^2 per channel on a surface facing the light.
    Directional { direction: Vec3, irradiance: Vec3 },
    /// `intensity` in W/sr per channel.
    Point { position: Vec3, intensity: Vec3 },
    /// `intensity` in W/sr per channel on the axis; full inside `inner_deg`, smooth falloff to
    /// zero at `outer_deg` (half-angles from the axis, degrees).
    Spot { position: Vec3, direction: Vec3, intensity: Vec3, inner_deg: f32, outer_deg: f32 },
}

#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    pub name: String,
    pub kind: LightKind,
    pub cast_shadows: bool,
    /// Applied to position and direction.
    pub motion: Motion,
}

impl Light {
    /// The light with its motion applied at time `t`.
    pub fn at_time(&self, t: f32) -> LightKind {
        let m = self.motion.matrix(t);
        match &self.kind {
            LightKind::Directional { direction, irradiance } => LightKind::Directional {
                direction: m.transform_vector3(*direction).normalize_or_zero(),
                irradiance: *irradiance,
            },
            LightKind::Point { position, intensity } => {
                LightKind::Point { position: m.transform_point3(*position), intensity: *intensity }
            }
            LightKind::Spot { position, direction, intensity, inner_deg, outer_deg } => LightKind::Spot {
                position: m.transform_point3(*position),
                direction: m.transform_vector3(*direction).normalize_or_zero(),
                intensity: *intensity,
                inner_deg: *inner_deg,
                outer_deg: *outer_deg,
            },
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ToneMap {
    /// Narkowicz's fitted ACES filmic curve.
    Aces,
    /// Reinhard x/(1+x) per channel.
    Reinhard,
    /// Clamp to [0,1]: no curve.
    Clamp,
}

/// `render.depth_prepass`: whether the G-buffer is drawn over a depth prepass of its opaque
/// draws, so that each covered pixel runs the G-buffer's fragment shader once. The image is the
/// same either way (tests/render.rs); what it costs is not: on an NVIDIA H100 the prepass and
/// the pass over it took 0.64 + 2.03 ms against 3.43 for the pass alone (Dabrovic's Sponza,
/// 1080p, `bench --raster-profile`), on lavapipe 1.2-1.3x the pass alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DepthPrepass {
    /// On where the device is a GPU, off on a CPU device (lavapipe), as measured.
    Auto,
    On,
    Off,
}

impl DepthPrepass {
    /// Whether a frame on a device (`cpu`: a CPU device) draws the prepass.
    pub fn resolve(self, cpu: bool) -> bool {
        match self {
            DepthPrepass::Auto => !cpu,
            DepthPrepass::On => true,
            DepthPrepass::Off => false,
        }
    }
}

/// Which global illumination a frame computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GiMode {
    /// Direct light only: no voxel volumes, no voxel passes.
    None,
    /// Voxel cone tracing.
    Vct,
    /// Reflective shadow maps (Dachsbacher & Stamminger 2005): one diffuse bounce gathered per
    /// pixel from the texels of each shadowed light's flux, normal and position maps; no
    /// visibility between the texel and the pixel.
    Rsm,
    /// Light propagation volumes (Kaplanyan & Dachsbacher 2010): the reflective shadow maps'
    /// texels injected as virtual point lights into a grid of 2-band spherical harmonics,
    /// propagated cell to cell with fuzzy occlusion by a geometry volume, looked up per pixel.
    Lpv,
    /// Both, split by distance (the async-compute study's mix): the RSM gather gives the light
    /// of texels nearer than two LPV cells (compute queue), the LPV the light that has
    /// travelled two cells or more (graphics queue); their sum is the indirect light.
    #[serde(rename = "rsm+lpv")]
    RsmLpv,
}

/// What the frame shows (`--view`): the final image or a debug view.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum View {
    Final,
    /// The voxelized linear albedo (first non-empty voxel along each camera ray).
    VoxelAlbedo,
    /// The voxelized normal, shown as 0.5 + 0.5 n.
    VoxelNormal,
    /// The voxelized emitted radiance.
    VoxelEmission,
    /// The lit voxels' outgoing radiance.
    VoxelRadiance,
    /// The radiance volumes as the cone tracer samples them, at `render.view_lod` (0 = full
    /// resolution, 1 = the directional volumes' level 0, fractional values blend) and
    /// `render.view_direction`, composited front to back along each camera ray.
    VoxelMip,
    /// The indirect light only (diffuse x albedo + specular), after AO.
    Indirect,
    /// The ambient occlusion factor as grey.
    Ao,
}

impl View {
    /// The view shows the lit image (final, indirect light or AO): a G-buffer, lighting and
    /// indirect light; the others show the voxels.
    pub fn is_lit(self) -> bool {
        matches!(self, View::Final | View::Indirect | View::Ao)
    }
}

/// How voxel lighting attenuates light by the voxel's (averaged) normal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VoxelAttenuation {
    /// The seed technique's: per-axis clamped cosines weighted by the squared normal components.
    /// Exact for a plane along an axis and for faces along the axes sharing a voxel (their
    /// average); a plane oblique to the axes (an arch's curve) gets too much light when turned
    /// from the light and too little when turned to it. On Dabrovic's Sponza the first
    /// gather's floors were 1.63 of the path tracer's with it, 1.35 with `NDotL` (ACCURACY.md,
    /// "The voxels' light by the mean normal's cosine").
    NormalWeighted,
    /// Plain max(N.L, 0) with the normalized average normal: exact for a voxel that one plane
    /// crosses. The default (the presets at 64^3 keep `NormalWeighted`, src/scene/preset.rs).
    NDotL,
    /// `NDotL`, and a voxel whose surfaces face different ways (the mean normal shorter than
    /// `ONE_PLANE` in glsl/include/voxel.glsl: an edge, a corner, both sides of a thin slab, a
    /// curved surface) shows each side the light of the faces it sees there, rather than the
    /// mean normal's light to every side: its sunlit top lights what is above it and not what is
    /// beside or under it. The voxelization sums, per side, the normals of the faces toward it
    /// weighted by the share of each the side sees (`side_normal` in voxel.glsl: 24 words of sums
    /// more, resolved into one R32G32B32A32_UINT volume); a side no face looks toward gets a face
    /// along its axis, max(s.L, 0). The voxel light stores one factor per side (one R32_UINT
    /// volume more); the directional volumes' first level applies them (glsl/aniso_mip.comp) to
    /// the voxel's whole radiance, its bounced light and emission too. The full-resolution
    /// radiance (the rays of `diffuse_rays`, cone samples finer than the first level) stays the
    /// mean normal's.
    PerSide,
}

/// How a cone sample filters the directional volumes (glsl/include/cone.glsl, ACCURACY.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ConeFilter {
    /// One trilinear lookup per volume and level of texels holding optical depth: a thin wall
    /// stays opaque however successive samples split it, but a footprint that a surface covers
    /// in part is nearly opaque (walls and open corners too bright).
    Trilinear,
    /// Texels hold opacity; two lookups per volume and level, one on each texel plane across
    /// the volume's axis on either side of the sample, each filtering opacity across the
    /// axis, blended in optical depth along it: walls stay opaque and partial cover occludes
    /// its part. Twice the lookups.
    TwoTap,
}

/// How much of a cone's footprint each of its samples keeps apart (glsl/include/cone.glsl,
/// ACCURACY.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Footprint {
    /// One sample per step over the whole footprint, composited with one transmittance: what
    /// covers part of the footprint at sample after sample (a wall beside the cone) is counted
    /// again each time, and parts covered in turn by different surfaces (a side wall, then a
    /// roof) leave light through.
    Whole,
    /// Four samples per step at half the texel size, one on each quarter of the footprint,
    /// each quarter a narrower cone from the same apex compositing its own transmittance:
    /// cover stays where it is across the cone. Steps half as long, so eight times the
    /// lookups.
    Quadrants,
    /// Steps as long as `whole`'s, each with one more sample per quarter of the footprint (at
    /// half the texel size), whose opacity is the share of the quarter something covers: each
    /// quarter keeps the largest share it has met, so a wall beside the cone is counted once,
    /// and the whole footprint's sample composites only the cover beyond the quarters' (what
    /// crosses the cone). Five times the lookups; with `gi.cone_filter = "two-tap"` the
    /// quarters' shares are filtered as opacity (ACCURACY.md, "Quarters' shares").
    Shares,
}

/// What a cone sample's optical depth is, from the three directional volumes it blends
/// (glsl/include/cone.glsl, ACCURACY.md "Sky light and leaks").
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Opacity {
    /// The volumes' optical depths averaged by the squared components of the cone's direction,
    /// an occupied texel holding at most ln 256. A wall crossed at angle theta from its normal
    /// holds cos(theta) of its optical depth: cones leak through walls they cross obliquely
    /// (a sealed room under a sky gets about a quarter of its open-roof light, 0.23 at 128^3),
    /// which also hides part of the cones' excess on closed scenes.
    Blend,
    /// Optical depth per unit of path as the length of (|d_a| tau_a), exact for a wall across
    /// any axis crossed at any angle and for isotropic cover, an occupied texel holding up to
    /// ln 65536: a sealed room gets 0.06 of its open-roof light, 0.024 with directional cover
    /// (what is left comes through coarse texels that straddle its walls). Closed scenes come
    /// out brighter.
    Layers,
}

/// How much of a voxel a surface in it makes opaque (glsl/include/voxel.glsl, ACCURACY.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VoxelCover {
    /// Every voxel a triangle touches is opaque (conservative voxelization): thin surfaces
    /// stand up to a voxel taller and thicker than they are, and openings narrower than about
    /// two voxels close.
    Touch,
    /// A voxel is as opaque as the share of its cross-section its surfaces cover (across each
    /// triangle's dominant axis, at most 1), and a surface stays opaque along every column it
    /// crosses: a voxel a surface only grazes (an edge, the top of a curtain) is that much
    /// opaque. The radiance volumes hold radiance premultiplied by it.
    Area,
    /// "area", and seen along each axis a voxel covers that share times how much of its
    /// surface faces that axis (|n_a| / max |n| of its mean normal n; the same along every axis
    /// where its normals disagree): a floor's voxels are open and dark seen edge-on, as the
    /// floor is (glsl/aniso_mip.comp).
    Directional,
}

/// What the cones see of a voxel that holds one plane from behind it (glsl/aniso_mip.comp,
/// ACCURACY.md "Planes dark from behind").
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PlaneBacks {
    /// Every voxel sends its light to every side: a sunlit floor's voxels light what lies
    /// under the floor, through the filtered volumes' partial cover.
    Lit,
    /// In the directional volumes a voxel whose faces are one plane (mean normal at least
    /// `ONE_PLANE` long) shows the cones that meet it from behind its emission only: its
    /// reflected and bounced light leave its front, as a two-sided Lambertian surface's do
    /// (the light of its back is another surface's). Its opacity is unchanged.
    Dark,
    /// "dark", and the backs that close a solid are left out of the directional volumes
    /// (glsl/voxel_backs.comp): a cone starts outside every solid, so what its rays meet at
    /// such a back (a block's far side, its top seen from under it) they met at its front; seen
    /// again, the object blocked a cone's partial footprint twice. The back of an open surface
    /// (a curtain, a floor seen from under it) stays dark and opaque.
    Closed,
}

/// How the voxel volumes are stored (render::voxel::bricks, docs/SPARSE.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VoxelLayout {
    /// Dense where it fits the device comfortably, bricks elsewhere
    /// (`render::budget::resolve_layout`): both render the same image, and dense is faster.
    Auto,
    /// N^3 texels per volume.
    Dense,
    /// Only the bricks of 8^3 texels that hold something, in pools found through a map.
    Bricks,
}

/// How voxel lighting decides whether a light reaches a voxel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VoxelOcclusion {
    /// The frame's shadow maps, read on the surface in the voxel (its outermost plane).
    ShadowMap,
    /// Marching the voxel grid towards the light (soft with `voxel_shadow_softness` > 0).
    Raymarch,
}

/// Where the indirect specular light of glossy and mirror surfaces comes from (`gi.specular`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpecularSource {
    /// None: glossy surfaces reflect only the lights directly.
    Off,
    /// A cone through the voxels along the reflection, its aperture from the lobe.
    Cone,
    /// Rays through the scene's triangles (ray queries): one along the reflection for mirrors,
    /// `gi.specular_rays` sampled from the Blinn-Phong lobe for glossy surfaces. Each hit is lit
    /// by the lights (shadow rays) and the voxels' diffuse indirect light.
    Rt,
}

impl SpecularSource {
    pub fn name(self) -> &'static str {
        match self {
            SpecularSource::Off => "off",
            SpecularSource::Cone => "cone",
            SpecularSource::Rt => "rt",
        }
    }
}

/// `"cone"`, `"rt"` or `"off"`; `true` and `false` (the key's old form) mean `"cone"` and `"off"`.
impl<'de> serde::Deserialize<'de> for SpecularSource {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(serde::Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Flag(bool),
            Name(String),
        }
        match Raw::deserialize(d)? {
            Raw::Flag(on) => Ok(if on { SpecularSource::Cone } else { SpecularSource::Off }),
            Raw::Name(n) => [SpecularSource::Off, SpecularSource::Cone, SpecularSource::Rt]
                .into_iter()
                .find(|s| s.name() == n)
                .ok_or_else(|| {
                    serde::de::Error::custom(format!(
                        "unknown specular source {n:?}: expected \"cone\", \"rt\" or \"off\""
                    ))
                }),
        }
    }
}

/// `gi.specular = "rt"`: the indirect light at each reflection ray's hit (`gi.rt_hit_indirect`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HitIndirect {
    /// The diffuse cones from the hit, as a pixel's own (`gi.diffuse_cones` of them).
    Cones,
    /// The hit voxel's own bounced light (bounced minus direct radiance): one lookup, at voxel
    /// resolution; none without bounces.
    Voxel,
}

/// How direct light is shadowed in the final image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DirectShadows {
    /// Shadow maps with PCF.
    ShadowMap,
    /// A cone traced through the voxels toward each light (soft; `shadow_cone_angle`); at most
    /// four shadow-casting lights.
    Cone,
    /// A shadow ray through the scene's triangles toward each light from every pixel (ray
    /// queries; hard and exact, alpha masks cut as in the path tracer), for the first four
    /// shadow-casting lights; any later ones keep their shadow maps. Any `gi.mode`.
    Rt,
}

impl DirectShadows {
    pub fn name(self) -> &'static str {
        match self {
            DirectShadows::ShadowMap => "shadow-map",
            DirectShadows::Cone => "cone",
            DirectShadows::Rt => "rt",
        }
    }
}

/// Direction shown by the `voxel-mip` view.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ViewDirection {
    /// Each camera ray samples the directional volumes along its own direction.
    #[serde(rename = "ray")]
    Ray,
    #[serde(rename = "+x")]
    PosX,
    #[serde(rename = "-x")]
    NegX,
    #[serde(rename = "+y")]
    PosY,
    #[serde(rename = "-y")]
    NegY,
    #[serde(rename = "+z")]
    PosZ,
    #[serde(rename = "-z")]
    NegZ,
}

/// The diffuse cone counts with a built-in cone set.
pub const DIFFUSE_CONE_COUNTS: [u32; 5] = [1, 4, 6, 9, 16];

/// Voxel global illumination settings (the `[gi]` table). Validated by [`GiSettings::validate`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GiSettings {
    pub mode: GiMode,
    /// Voxels along each side of the cubic grid: a power of two in 8..=512.
    pub voxel_resolution: u32,
    /// How the voxel volumes are stored: bricks of 8^3 where the scene is (default), or
    /// dense N^3 (docs/SPARSE.md).
    pub voxel_layout: VoxelLayout,
    pub attenuation: VoxelAttenuation,
    pub occlusion: VoxelOcclusion,
    /// Ray-marched shadows only: 0 = hard; larger values soften with distance (nu accumulation).
    pub voxel_shadow_softness: f32,
    /// Light bounces by per-voxel cone tracing in each voxel update (0 = direct light in the
    /// voxels only).
    pub bounces: u32,
    /// Each update's first bounce gathers the previous update's bounced light instead of the
    /// direct light alone, so bounces accumulate over updates (N updates give N × `bounces`).
    pub bounce_feedback: bool,
    /// With feedback, the bounces of the first update (when there is nothing to feed back),
    /// so that a single frame is already converged; at least `bounces`.
    pub first_update_bounces: u32,
    /// With feedback and 4 or more first-update bounces, the first update adds the geometric
    /// tail of the bounces it does not run: each voxel's last increment times r / (1 - r), r
    /// the ratio of what the two bounces before it added over the whole grid, per channel
    /// (glsl/voxel_bounce_tail.comp).
    pub bounce_tail: bool,
    /// Diffuse cones per pixel (and per voxel in bounces, unless `bounce_cones` says
    /// otherwise): one of [`DIFFUSE_CONE_COUNTS`].
    pub diffuse_cones: u32,
    /// Diffuse cones per voxel in the bounces: one of [`DIFFUSE_CONE_COUNTS`], or 0 for
    /// `diffuse_cones`.
    pub bounce_cones: u32,
    /// With `bounce_feedback`, each update after the first gathers the bounce for one in
    /// this many static voxels (by workgroups of the work list), in turn (dynamic voxels every
    /// update), so a bounce costs 1/N of a full one and every voxel's gathered light is at
    /// most N updates old; 1 = all. A static scene converges to the same light; light that
    /// moves takes about N times as many updates to settle (ACCURACY.md).
    pub bounce_interleave: u32,
    /// Diagnostic: gather each pixel's diffuse light with this many cosine-distributed rays
    /// through the full-resolution voxels (exact for the voxelized scene, noisy) instead of
    /// the diffuse cones; 0 = cones. Separates the voxels' error from the cones'.
    pub diffuse_rays: u32,
    /// Full aperture of each diffuse cone in degrees; 0 = automatic (each cone spans the solid
    /// angle of its share of the hemisphere).
    pub diffuse_cone_angle: f32,
    /// The indirect specular light (only where some material has a specular colour): a cone
    /// (default), rays (`"rt"`, on devices with ray queries) or none (`"off"`).
    pub specular: SpecularSource,
    /// `specular = "rt"`: rays per traced pixel on glossy surfaces (1..=64); mirrors take one.
    pub specular_rays: u32,
    /// `specular = "rt"`: frames whose rays are averaged while the view and the scene stand
    /// still (1..=256; 1 = each frame's rays alone). The average starts again when the camera,
    /// a light or a moving object changes; past this many frames it becomes a moving average.
    pub specular_history: u32,
    /// `specular = "rt"`: where a ray's hit gets its indirect light. The voxel's own bounced
    /// light by default: as accurate as cones from the hit on the Cornell boxes at a sixth of
    /// the cost on lavapipe, which buys 16 rays for less than 4 with cones (ACCURACY.md).
    pub rt_hit_indirect: HitIndirect,
    /// Multiply the cone-traced indirect light by the diffuse cones' ambient occlusion, as many
    /// engines do. Off by default: the cones' front-to-back compositing already occludes the
    /// light they gather, so this counts occlusion twice (ACCURACY.md measures what it costs).
    /// `--view ao` shows the factor whatever this says. Occlusion is weighted by
    /// f(r) = 1 / (1 + falloff r), r in units of the voxel grid's side.
    pub ao: bool,
    pub ao_falloff: f32,
    /// How direct light is shadowed.
    pub shadows: DirectShadows,
    /// Full aperture of the shadow cones in degrees.
    pub shadow_cone_angle: f32,
    /// How each cone sample filters the directional volumes (opacity across the cone, optical
    /// depth along it: ACCURACY.md).
    pub cone_filter: ConeFilter,
    /// How a cone sample's optical depth follows the walls it crosses (leaks: ACCURACY.md).
    pub opacity: Opacity,
    /// Whether the cones of each pixel (diffuse, specular, shadow) keep the parts of their
    /// footprints apart (partial cover along the path: ACCURACY.md).
    pub footprint: Footprint,
    /// The same for the cones of the voxel bounce. Separate because the two cost and buy
    /// differently: in lavapipe's sweeps the bounce's quadrants tripled the frame and were on
    /// neither front, where the pixels' gave the whole FLIP gain; they keep a closed room's sky
    /// out (ACCURACY.md, "Quadrants where they pay").
    pub bounce_footprint: Footprint,
    /// How much of a voxel its surfaces make opaque (thin surfaces and narrow openings).
    pub voxel_cover: VoxelCover,
    /// What the cones see of a one-plane voxel from behind: its light (`lit`), its emission
    /// only (`dark`), or that and nothing where the back closes a solid (`closed`, the default:
    /// ACCURACY.md, "Backs that close a solid").
    pub plane_backs: PlaneBacks,
    /// Step along a cone as a fraction of its diameter (beta).
    pub step: f32,
    /// Longest cone in world units; 0 = the grid's diagonal.
    pub max_distance: f32,
    /// Extra distance (voxels) cones start off the surface, beyond the clearance that already
    /// keeps every cone sample off the surface's own voxels.
    pub start_offset: f32,
    /// Trace at 1/downsample of the image resolution, then upsample (depth- and normal-aware).
    pub downsample: u32,
    /// Revoxelize dynamic objects every N frames; 0 = only on demand (`Renderer::request_voxel_update`).
    pub update_interval: u32,
    /// `mode = "rsm"`: side of each reflective shadow map in texels (a power of two in 16..=2048).
    pub rsm_size: u32,
    /// `mode = "rsm"`: RSM texels gathered per pixel and light view (1..=4096).
    pub rsm_samples: u32,
    /// `mode = "rsm"`: radius of the gathered disc around the pixel's position in the map, as a
    /// fraction of the map's side (0 < r <= 2; 0.71 reaches every texel from the map's centre).
    pub rsm_radius: f32,
    /// `mode = "lpv"`: cells along each side of the cubic propagation grid (a power of two in
    /// 4..=128).
    pub lpv_resolution: u32,
    /// `mode = "lpv"`: propagation steps (0..=128); light travels one cell per step.
    pub lpv_steps: u32,
    /// `mode = "lpv"`: fuzzy occlusion of propagated light by the geometry volume (from the
    /// reflective shadow maps' texels), from the second step on.
    pub lpv_occlusion: bool,
}

impl Default for GiSettings {
    fn default() -> Self {
        GiSettings {
            mode: GiMode::Vct,
            voxel_resolution: 128,
            voxel_layout: VoxelLayout::Auto,
            attenuation: VoxelAttenuation::NDotL,
            occlusion: VoxelOcclusion::ShadowMap,
            voxel_shadow_softness: 0.0,
            bounces: 1,
            bounce_feedback: true,
            first_update_bounces: 4,
            bounce_tail: true,
            diffuse_cones: 16,
            bounce_cones: 0,
            bounce_interleave: 4,
            diffuse_rays: 0,
            diffuse_cone_angle: 0.0,
            specular: SpecularSource::Cone,
            specular_rays: 16,
            specular_history: 16,
            rt_hit_indirect: HitIndirect::Voxel,
            ao: false,
            ao_falloff: 4.0,
            shadows: DirectShadows::ShadowMap,
            shadow_cone_angle: 6.0,
            cone_filter: ConeFilter::Trilinear,
            opacity: Opacity::Blend,
            footprint: Footprint::Whole,
            bounce_footprint: Footprint::Whole,
            voxel_cover: VoxelCover::Touch,
            plane_backs: PlaneBacks::Closed,
            step: 0.5,
            max_distance: 0.0,
            start_offset: 0.0,
            downsample: 1,
            update_interval: 1,
            rsm_size: 256,
            rsm_samples: 128,
            rsm_radius: 1.42,
            lpv_resolution: 16,
            lpv_steps: 16,
            lpv_occlusion: true,
        }
    }
}

impl GiSettings {
    /// The first update adds the bounce tail: `bounce_tail`, with bounces and feedback and 4 or
    /// more first-update bounces (two records after a first bounce, then the one it extrapolates).
    pub fn first_update_tail(&self) -> bool {
        self.bounce_tail && self.bounces > 0 && self.bounce_feedback && self.bounces.max(self.first_update_bounces) >= 4
    }

    /// Check ranges; `Err((key, message))` names the first bad key (without the `gi.` prefix).
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let finite = [
            ("voxel_shadow_softness", self.voxel_shadow_softness),
            ("diffuse_cone_angle", self.diffuse_cone_angle),
            ("ao_falloff", self.ao_falloff),
            ("shadow_cone_angle", self.shadow_cone_angle),
            ("step", self.step),
            ("max_distance", self.max_distance),
            ("start_offset", self.start_offset),
        ];
        for (key, v) in finite {
            if !v.is_finite() {
                return Err((key, format!("{v} is not finite")));
            }
            if v < 0.0 {
                return Err((key, format!("{v} must be >= 0")));
            }
        }
        let res = self.voxel_resolution;
        if !(8..=512).contains(&res) || !res.is_power_of_two() {
            return Err(("voxel_resolution", format!("{res} is not a power of two in 8..=512")));
        }
        if self.bounces > 16 {
            return Err(("bounces", format!("{} is not in 0..=16", self.bounces)));
        }
        if self.first_update_bounces > 16 {
            return Err(("first_update_bounces", format!("{} is not in 0..=16", self.first_update_bounces)));
        }
        if !(1..=64).contains(&self.specular_rays) {
            return Err(("specular_rays", format!("{} is not in 1..=64", self.specular_rays)));
        }
        if !(1..=256).contains(&self.specular_history) {
            return Err(("specular_history", format!("{} is not in 1..=256", self.specular_history)));
        }
        if self.diffuse_rays > 64 {
            return Err(("diffuse_rays", format!("{} is not in 0..=64", self.diffuse_rays)));
        }
        if self.bounce_cones != 0 && !DIFFUSE_CONE_COUNTS.contains(&self.bounce_cones) {
            let m = format!("{} is not 0 (as diffuse_cones) or one of {DIFFUSE_CONE_COUNTS:?}", self.bounce_cones);
            return Err(("bounce_cones", m));
        }
        if !(1..=16).contains(&self.bounce_interleave) {
            return Err(("bounce_interleave", format!("{} is not in 1..=16", self.bounce_interleave)));
        }
        if !DIFFUSE_CONE_COUNTS.contains(&self.diffuse_cones) {
            return Err(("diffuse_cones", format!("{} is not one of {DIFFUSE_CONE_COUNTS:?}", self.diffuse_cones)));
        }
        for (key, v) in [("diffuse_cone_angle", self.diffuse_cone_angle), ("shadow_cone_angle", self.shadow_cone_angle)]
        {
            if v > 179.0 {
                return Err((key, format!("{v} degrees is not a cone aperture (0..=179)")));
            }
        }
        if self.shadow_cone_angle < 0.01 {
            return Err(("shadow_cone_angle", format!("{} degrees is below 0.01", self.shadow_cone_angle)));
        }
        if !(0.01..=4.0).contains(&self.step) {
            return Err(("step", format!("{} is not in 0.01..=4", self.step)));
        }
        if self.start_offset > 16.0 {
            return Err(("start_offset", format!("{} voxels is not in 0..=16", self.start_offset)));
        }
        if !(1..=8).contains(&self.downsample) {
            return Err(("downsample", format!("{} is not in 1..=8", self.downsample)));
        }
        self.validate_rsm()
    }

    /// The mode renders reflective shadow maps (RSM gathers from them, LPV injects them).
    pub fn uses_rsm(&self) -> bool {
        matches!(self.mode, GiMode::Rsm | GiMode::Lpv | GiMode::RsmLpv)
    }

    /// The per-pixel RSM gather runs (`rsm`, `rsm+lpv`).
    pub fn gathers_rsm(&self) -> bool {
        matches!(self.mode, GiMode::Rsm | GiMode::RsmLpv)
    }

    /// A light propagation volume is built (`lpv`, `rsm+lpv`).
    pub fn uses_lpv(&self) -> bool {
        matches!(self.mode, GiMode::Lpv | GiMode::RsmLpv)
    }

    fn validate_rsm(&self) -> Result<(), (&'static str, String)> {
        let size = self.rsm_size;
        if !(16..=2048).contains(&size) || !size.is_power_of_two() {
            return Err(("rsm_size", format!("{size} is not a power of two in 16..=2048")));
        }
        if !(1..=4096).contains(&self.rsm_samples) {
            return Err(("rsm_samples", format!("{} is not in 1..=4096", self.rsm_samples)));
        }
        let r = self.rsm_radius;
        if !(r.is_finite() && r > 0.0 && r <= 2.0) {
            return Err(("rsm_radius", format!("{r} is not in (0, 2] (a fraction of the map's side)")));
        }
        let res = self.lpv_resolution;
        if !(4..=128).contains(&res) || !res.is_power_of_two() {
            return Err(("lpv_resolution", format!("{res} is not a power of two in 4..=128")));
        }
        if self.lpv_steps > 128 {
            return Err(("lpv_steps", format!("{} is not in 0..=128", self.lpv_steps)));
        }
        Ok(())
    }
}

/// Per-scene render settings (the `[render]` table).
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Scene time in seconds at which motion is evaluated.
    pub time: f32,
    /// Exposure in EV stops: displayed value = radiance * 2^exposure before the tone map.
    pub exposure: f32,
    /// `render.exposure = "auto"`: each display image (the window, PNGs) is exposed so that
    /// its log-average luminance lands on middle grey (glsl/exposure.comp for rendered frames,
    /// metrics::auto_exposure for path-traced ones), added to `exposure`. EXR output is linear
    /// radiance either way.
    pub exposure_auto: bool,
    pub tonemap: ToneMap,
    /// Side of each shadow-map view in texels.
    pub shadow_map_size: u32,
    /// Shadow-map cascades of a directional light, fitted to slices of the camera's view
    /// (0..=4). A directional light also has one view over the whole scene, for what lies
    /// outside the cascades (voxels out of view).
    pub shadow_cascades: u32,
    /// PCF kernel radius in shadow-map texels (0 = single hardware-filtered tap).
    pub shadow_filter_radius: f32,
    /// Bias against shadow acne in shadow-map texels: the lookup moves towards the light by
    /// the margin a normal offset of this many texels gives a planar receiver.
    pub shadow_normal_bias: f32,
    /// What the frame shows.
    pub view: View,
    /// Level of detail shown by the `voxel-mip` view (0..=16).
    pub view_lod: f32,
    /// Direction shown by the `voxel-mip` view.
    pub view_direction: ViewDirection,
    /// Supersampling: k x k samples per output pixel on an ordered grid, averaged in linear
    /// light (a box filter over the pixel; the reference then jitters its paths over the same
    /// footprint). 1 = one sample at the pixel centre.
    pub supersample: u32,
    /// The G-buffer over a depth prepass of its opaque draws.
    pub depth_prepass: DepthPrepass,
    pub gi: GiSettings,
}

impl RenderSettings {
    /// The size the frame is rendered at: the output size times `supersample`.
    pub fn internal_size(&self) -> (u32, u32) {
        (self.width * self.supersample, self.height * self.supersample)
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 512,
            height: 512,
            time: 0.0,
            exposure: 0.0,
            exposure_auto: false,
            tonemap: ToneMap::Aces,
            shadow_map_size: 1024,
            shadow_cascades: 3,
            shadow_filter_radius: 1.5,
            shadow_normal_bias: 1.5,
            view: View::Final,
            view_lod: 0.0,
            view_direction: ViewDirection::Ray,
            supersample: 1,
            depth_prepass: DepthPrepass::Auto,
            gi: GiSettings::default(),
        }
    }
}
