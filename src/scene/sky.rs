//! `[sky]`: the light that arrives from outside the scene, what every ray that leaves it sees
//! (format: `scenes/FORMAT.md`). A constant radiance, a gradient linear in the direction's
//! height (zenith, horizon, ground), or an equirectangular OpenEXR image of linear radiance.
//!
//! Directions map to the image as latitude and longitude about +y: row `v` (0 at the top) is
//! the polar angle theta = pi v from +y, column `u` the azimuth phi = 2 pi (u - 1/2) from -z
//! towards +x, so the image's centre column faces -z and its quarter to the right +x.
//! `rotation` turns the sky about +y (degrees, counter-clockwise seen from above: by the
//! right-hand rule, so 90 turns what faced -z to face -x).

use super::error::SceneError;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// `[sky]` as written.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SkyDef {
    #[serde(rename = "type")]
    pub kind: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radiance: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zenith: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizon: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ground: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f32>,
}

pub(crate) const SKY_KEYS: &[&str] = &["type", "radiance", "zenith", "horizon", "ground", "image", "rotation", "scale"];

/// The sky of a scene, its `scale` applied.
#[derive(Debug, Clone, PartialEq)]
pub struct Sky {
    pub kind: SkyKind,
    /// Turn about +y, degrees (an image's; the other kinds look the same at any turn).
    pub rotation_deg: f32,
    /// `scale` as the file gave it (already applied to the radiance).
    pub scale: f32,
}

#[derive(Debug, Clone, PartialEq)]
pub enum SkyKind {
    /// Radiance W/(sr m^2) per channel, the same from every direction.
    Constant(Vec3),
    /// Linear in the direction's height y = cos(theta): horizon + (zenith - horizon) y above the
    /// horizon, horizon + (ground - horizon) (-y) below it.
    Gradient { zenith: Vec3, horizon: Vec3, ground: Vec3 },
    /// An equirectangular image (module docs for the mapping).
    Image(Arc<SkyImage>),
}

/// Linear radiance W/(sr m^2), RGB per texel, top row first, the scene's `scale` applied.
#[derive(Clone, PartialEq)]
pub struct SkyImage {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<f32>,
}

impl std::fmt::Debug for SkyImage {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "SkyImage({}, {}x{})", self.path.display(), self.width, self.height)
    }
}

impl SkyImage {
    pub fn texel(&self, x: u32, y: u32) -> Vec3 {
        let i = (y as usize * self.width as usize + x as usize) * 3;
        Vec3::new(self.rgb[i], self.rgb[i + 1], self.rgb[i + 2])
    }
}

/// The unit direction at image coordinates (u, v) in [0, 1]^2 of a sky turned by `rotation`
/// radians (module docs).
pub fn equirect_dir(u: f32, v: f32, rotation: f32) -> Vec3 {
    let theta = std::f32::consts::PI * v;
    let phi = std::f32::consts::TAU * (u - 0.5) - rotation;
    let s = theta.sin();
    Vec3::new(s * phi.sin(), theta.cos(), -s * phi.cos())
}

/// The image coordinates (u in [0, 1), v in [0, 1]) of unit direction `d` of a sky turned by
/// `rotation` radians; the inverse of [`equirect_dir`].
pub fn equirect_uv(d: Vec3, rotation: f32) -> (f32, f32) {
    let phi = d.x.atan2(-d.z) + rotation;
    let u = (phi / std::f32::consts::TAU + 0.5).rem_euclid(1.0);
    let v = d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
    (u, v)
}

impl Sky {
    /// The radiance arriving from direction `d` (unit, pointing away from the scene): an
    /// image's nearest texel, as the path tracer reads it.
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        match &self.kind {
            SkyKind::Constant(c) => *c,
            SkyKind::Gradient { zenith, horizon, ground } => gradient(*zenith, *horizon, *ground, d.y),
            SkyKind::Image(img) => {
                let (u, v) = equirect_uv(d, self.rotation_deg.to_radians());
                let x = ((u * img.width as f32) as u32).min(img.width - 1);
                let y = ((v * img.height as f32) as u32).min(img.height - 1);
                img.texel(x, y)
            }
        }
    }

    /// The largest channel of the radiance averaged over the sphere (the scene's typical
    /// radiance from its sky: render::lights::radiance_scale).
    pub fn mean_radiance(&self) -> f32 {
        match &self.kind {
            SkyKind::Constant(c) => c.max_element(),
            // Over the sphere y is uniform in [-1, 1]: each half averages to its middle.
            SkyKind::Gradient { zenith, horizon, ground } => {
                ((*zenith + *horizon) * 0.25 + (*ground + *horizon) * 0.25).max_element()
            }
            SkyKind::Image(img) => {
                let (mut sum, mut weight) = (glam::DVec3::ZERO, 0.0f64);
                for y in 0..img.height {
                    let w = (std::f64::consts::PI * (y as f64 + 0.5) / img.height as f64).sin();
                    for x in 0..img.width {
                        sum += img.texel(x, y).as_dvec3() * w;
                        weight += w;
                    }
                }
                (sum / weight.max(1e-30)).max_element() as f32
            }
        }
    }

    /// One line for `info` and logs.
    pub fn describe(&self) -> String {
        match &self.kind {
            SkyKind::Constant(c) => format!("constant {c} W/(sr m^2)"),
            SkyKind::Gradient { zenith, horizon, ground } => {
                format!("gradient: zenith {zenith}, horizon {horizon}, ground {ground} W/(sr m^2)")
            }
            SkyKind::Image(img) => format!(
                "image {} ({}x{}), turned {} degrees, mean {:.4} W/(sr m^2)",
                img.path.display(),
                img.width,
                img.height,
                self.rotation_deg,
                self.mean_radiance()
            ),
        }
    }
}

/// The gradient sky's radiance at direction height y.
pub fn gradient(zenith: Vec3, horizon: Vec3, ground: Vec3, y: f32) -> Vec3 {
    if y >= 0.0 {
        horizon + (zenith - horizon) * y.min(1.0)
    } else {
        horizon + (ground - horizon) * (-y).min(1.0)
    }
}

/// What `build_sky` needs of the scene loader: colour and scalar checks and asset lookup.
pub(crate) trait SkyContext {
    fn color(&self, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError>;
    fn scalar(&self, key: &str, v: f32) -> Result<f32, SceneError>;
    fn invalid(&self, key: &str, message: String) -> SceneError;
    fn resolve(&self, name: &str) -> Result<PathBuf, SceneError>;
}

/// `[sky]`, checked: a known type with the keys it needs and no others, colours finite and
/// >= 0, a positive finite scale, a loadable image. `None` for no table or `type = "none"`.
pub(crate) fn build_sky(ctx: &impl SkyContext, def: Option<&SkyDef>) -> Result<Option<Sky>, SceneError> {
    let Some(def) = def else { return Ok(None) };
    check_sky_keys(ctx, def)?;
    let scale = ctx.scalar("sky.scale", def.scale.unwrap_or(1.0))?;
    // Finite already (Ctx::scalar).
    if scale < 0.0 {
        return Err(ctx.invalid("sky.scale", format!("{scale} must be >= 0 (it multiplies the sky's radiance)")));
    }
    let rotation_deg = ctx.scalar("sky.rotation", def.rotation.unwrap_or(0.0))?;
    let color = |key: &str, v: Option<[f32; 3]>| -> Result<Vec3, SceneError> {
        Ok(ctx.color(&format!("sky.{key}"), v.unwrap_or([0.0; 3]))? * scale)
    };
    let kind = match def.kind.as_str() {
        "none" => return Ok(None),
        "constant" => SkyKind::Constant(color("radiance", def.radiance)?),
        "gradient" => SkyKind::Gradient {
            zenith: color("zenith", def.zenith)?,
            horizon: color("horizon", def.horizon)?,
            ground: color("ground", def.ground)?,
        },
        _ => {
            let name = def.image.as_deref().unwrap_or_default();
            let path = ctx.resolve(name)?;
            SkyKind::Image(Arc::new(load_sky_image(&path, scale)?))
        }
    };
    Ok(Some(Sky { kind, rotation_deg, scale }))
}

/// The sky's `type` is known, and it has the keys that type needs and no others.
fn check_sky_keys(ctx: &impl SkyContext, def: &SkyDef) -> Result<(), SceneError> {
    let (allowed, required): (&[&str], &[&str]) = match def.kind.as_str() {
        // No sky, whatever else the table says: `--set sky.type=none` turns any sky off.
        "none" => return Ok(()),
        "constant" => (&["radiance"], &["radiance"]),
        "gradient" => (&["zenith", "horizon", "ground"], &["zenith", "horizon", "ground"]),
        "image" => (&["image", "rotation"], &["image"]),
        other => {
            return Err(ctx.invalid(
                "sky.type",
                format!("unknown sky type `{other}`; expected one of: constant, gradient, image, none"),
            ))
        }
    };
    let present = [
        ("radiance", def.radiance.is_some()),
        ("zenith", def.zenith.is_some()),
        ("horizon", def.horizon.is_some()),
        ("ground", def.ground.is_some()),
        ("image", def.image.is_some()),
        ("rotation", def.rotation.is_some()),
    ];
    let misplaced = |k: &str| {
        let message =
            format!("`{k}` does not apply to a {} sky (it takes: {}, plus scale)", def.kind, allowed.join(", "));
        ctx.invalid(&format!("sky.{k}"), message)
    };
    let missing = |k: &str| ctx.invalid(&format!("sky.{k}"), format!("a {} sky needs `{k}`", def.kind));
    super::file::check_keys(&present, (allowed, required), misplaced, missing)
}

/// Reads an equirectangular OpenEXR image of linear radiance (any channel layout the decoder
/// reads; alpha ignored), `scale` applied. Refuses other formats (their values are not
/// radiance), a size that is not 2:1 within a texel, and texels that are negative or not finite.
pub fn load_sky_image(path: &Path, scale: f32) -> Result<SkyImage, SceneError> {
    let err = |message: String| SceneError::Texture { path: path.to_path_buf(), message };
    super::text::check_regular(path, super::text::MAX_ASSET_BYTES)?;
    let reader = image::ImageReader::open(path)
        .map_err(|e| err(format!("cannot read the sky image (sky.image): {e}")))?
        .with_guessed_format()
        .map_err(|e| err(format!("cannot read the sky image (sky.image): {e}")))?;
    if reader.format() != Some(image::ImageFormat::OpenExr) {
        return Err(err(
            "the sky image (sky.image) must be an OpenEXR file of linear radiance; convert the image to EXR \
             (8-bit formats hold display values, not radiance)"
                .to_owned(),
        ));
    }
    let img = reader
        .decode()
        .map_err(|e| err(format!("cannot decode the sky image (sky.image): {e}; use a valid OpenEXR file")))?
        .to_rgb32f();
    let (width, height) = img.dimensions();
    if width < 2 || height < 1 || width.abs_diff(2 * height) > 1 {
        return Err(err(format!(
            "the sky image is {width}x{height}; an equirectangular image is twice as wide as it is high \
             (360 by 180 degrees)"
        )));
    }
    let mut rgb = img.into_raw();
    if let Some(i) = rgb.iter().position(|c| !c.is_finite() || *c < 0.0) {
        let texel = i / 3;
        return Err(err(format!(
            "the sky image's texel ({}, {}) holds {}; radiance must be finite and >= 0",
            texel % width as usize,
            texel / width as usize,
            rgb[i]
        )));
    }
    rgb.iter_mut().for_each(|c| *c *= scale);
    Ok(SkyImage { path: path.to_path_buf(), width, height, rgb })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equirect_mapping_round_trips_and_faces_as_documented() {
        let approx = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
        assert!(approx(equirect_dir(0.5, 0.5, 0.0), Vec3::NEG_Z), "centre faces -z");
        assert!(approx(equirect_dir(0.75, 0.5, 0.0), Vec3::X), "a quarter right faces +x");
        assert!(approx(equirect_dir(0.3, 0.0, 0.0), Vec3::Y), "top row is the zenith");
        // Turned 90 degrees counter-clockwise from above: what faced -z faces -x.
        assert!(approx(equirect_dir(0.5, 0.5, std::f32::consts::FRAC_PI_2), Vec3::NEG_X));
        for (u, v) in [(0.1, 0.2), (0.6, 0.7), (0.99, 0.5)] {
            for rot in [0.0, 1.0, -2.5] {
                let (u2, v2) = equirect_uv(equirect_dir(u, v, rot), rot);
                assert!((u2 - u).abs() < 1e-4 && (v2 - v).abs() < 1e-4, "({u}, {v}) turned {rot}: ({u2}, {v2})");
            }
        }
    }

    #[test]
    fn gradient_is_linear_in_height_on_each_side() {
        let (z, h, g) = (Vec3::new(1.0, 2.0, 3.0), Vec3::splat(0.5), Vec3::ZERO);
        assert_eq!(gradient(z, h, g, 1.0), z);
        assert_eq!(gradient(z, h, g, 0.0), h);
        assert_eq!(gradient(z, h, g, -1.0), g);
        assert!((gradient(z, h, g, 0.5) - (h + z) * 0.5).length() < 1e-6);
        let sky = Sky { kind: SkyKind::Gradient { zenith: z, horizon: h, ground: g }, rotation_deg: 0.0, scale: 1.0 };
        assert!((sky.mean_radiance() - ((3.0 + 0.5) * 0.25 + 0.5 * 0.25)).abs() < 1e-6);
    }
}
