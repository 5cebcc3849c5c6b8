//! The invariants every loaded [`Scene`] satisfies, as a checkable function: the fuzz targets
//! (tools/fuzz) and the bad-input tests assert them on whatever the loader accepts.

use super::types::*;
use glam::Vec3;

fn finite_non_negative(v: Vec3) -> bool {
    v.is_finite() && v.min_element() >= 0.0
}

impl Scene {
    /// Checks what the renderer relies on: finite geometry with unit normals, in-range
    /// indices and references, finite camera matrices and lights at `settings.time`. Returns
    /// the first violation found. The loader guarantees all of this; this is the check.
    pub fn check_invariants(&self) -> Result<(), String> {
        let owner = self.check_objects()?;
        for (mi, m) in self.meshes.iter().enumerate() {
            self.check_mesh(mi, m, owner[mi])?;
        }
        for (k, m) in self.materials.iter().enumerate() {
            self.check_material(k, m)?;
        }
        for (k, tx) in self.textures.iter().enumerate() {
            if tx.width == 0 || tx.height == 0 || tx.rgba8.len() != tx.width as usize * tx.height as usize * 4 {
                return Err(format!("texture {k}: {}x{} with {} bytes", tx.width, tx.height, tx.rgba8.len()));
            }
        }
        self.check_camera()?;
        self.check_lights()?;
        self.check_settings()
    }

    /// Checks the objects' transforms and that no mesh belongs to two objects; returns each
    /// mesh's object.
    fn check_objects(&self) -> Result<Vec<Option<usize>>, String> {
        let t = self.settings.time;
        let mut owner = vec![None; self.meshes.len()];
        for (oi, o) in self.objects.iter().enumerate() {
            if !o.transform.is_finite() || !o.model_matrix(t).is_finite() {
                return Err(format!("object {oi} `{}`: non-finite transform", o.name));
            }
            for &mi in &o.meshes {
                let Some(slot) = owner.get_mut(mi as usize) else {
                    return Err(format!("object {oi}: mesh index {mi} out of range ({})", self.meshes.len()));
                };
                if let Some(other) = slot.replace(oi) {
                    return Err(format!("mesh {mi} belongs to objects {other} and {oi}"));
                }
            }
        }
        Ok(owner)
    }

    /// Checks mesh `mi` (owned by object `owner`): matching, finite vertex attributes with unit
    /// normals, whole in-range triangles, its material, and finite bounds in object and world
    /// space.
    fn check_mesh(&self, mi: usize, m: &Mesh, owner: Option<usize>) -> Result<(), String> {
        let what = |s: String| format!("mesh {mi} `{}`: {s}", m.name);
        let n = m.positions.len();
        if m.normals.len() != n || m.uvs.len() != n {
            return Err(what(format!("{n} positions, {} normals, {} uvs", m.normals.len(), m.uvs.len())));
        }
        if let Some(p) = m.positions.iter().find(|p| !p.is_finite()) {
            return Err(what(format!("non-finite position {p}")));
        }
        if let Some(nr) = m.normals.iter().find(|v| !v.is_finite() || (v.length() - 1.0).abs() > 1e-3) {
            return Err(what(format!("normal {nr} is not a finite unit vector")));
        }
        if let Some(uv) = m.uvs.iter().find(|v| !v.is_finite()) {
            return Err(what(format!("non-finite uv {uv}")));
        }
        if m.indices.len() % 3 != 0 {
            return Err(what(format!("{} indices, not a multiple of 3", m.indices.len())));
        }
        if let Some(i) = m.indices.iter().find(|&&i| i as usize >= n) {
            return Err(what(format!("index {i} out of range ({n} vertices)")));
        }
        if m.material as usize >= self.materials.len() {
            return Err(what(format!("material {} out of range ({})", m.material, self.materials.len())));
        }
        if n > 0 && !(m.bounds.min.is_finite() && m.bounds.max.is_finite() && m.bounds.extent().is_finite()) {
            return Err(what(format!("bounds {:?} not finite", m.bounds)));
        }
        let model = match owner {
            Some(oi) => self.objects[oi].model_matrix(self.settings.time),
            None => return Err(what("belongs to no object".to_owned())),
        };
        if n > 0 {
            let w = m.bounds.transformed(&model);
            if !(w.min.is_finite() && w.max.is_finite() && w.extent().is_finite()) {
                return Err(what(format!("world-space bounds {w:?} not finite")));
            }
        }
        Ok(())
    }

    /// Checks material `k`: finite, non-negative values and textures that exist and are of the
    /// kind each slot samples.
    fn check_material(&self, k: usize, m: &Material) -> Result<(), String> {
        let colours = [m.albedo, m.specular, m.emission];
        if !(colours.into_iter().all(finite_non_negative) && m.shininess.is_finite() && m.shininess >= 0.0) {
            return Err(format!("material {k} `{}`: non-finite or negative values", m.name));
        }
        let maps = [
            (m.albedo_texture, &[TextureUse::Color][..]),
            (m.mask_texture, &[TextureUse::Mask][..]),
            (m.normal_texture, &[TextureUse::Normal, TextureUse::Height][..]),
        ];
        for (map, uses) in maps {
            let Some(i) = map else { continue };
            match self.textures.get(i as usize) {
                None => return Err(format!("material {k} `{}`: texture index out of range", m.name)),
                Some(t) if !uses.contains(&t.usage) => {
                    return Err(format!("material {k} `{}`: texture {i} is a {:?} map here", m.name, t.usage))
                }
                Some(_) => {}
            }
        }
        if !m.relief.value().is_finite() {
            return Err(format!("material {k} `{}`: relief not finite", m.name));
        }
        Ok(())
    }

    /// Checks the camera: finite, a field of view and clip range it can project with.
    fn check_camera(&self) -> Result<(), String> {
        let c = &self.camera;
        let aspect = self.settings.width as f32 / self.settings.height as f32;
        let camera_ok = c.position.is_finite()
            && c.target.is_finite()
            && c.up.is_finite()
            && c.fov_y_deg > 0.0
            && c.fov_y_deg < 180.0
            && c.near > 0.0
            && c.far > c.near
            && c.far.is_finite()
            && c.view().is_finite()
            && c.projection(aspect).is_finite();
        if !camera_ok {
            return Err(format!("camera {c:?} is not usable"));
        }
        Ok(())
    }

    /// Checks every light at `settings.time`: finite, non-negative, unit directions and spot
    /// cone angles in range.
    fn check_lights(&self) -> Result<(), String> {
        let t = self.settings.time;
        for (k, l) in self.lights.iter().enumerate() {
            let ok = match l.at_time(t) {
                LightKind::Point { position, intensity } => position.is_finite() && finite_non_negative(intensity),
                LightKind::Directional { direction, irradiance } => {
                    direction.is_normalized() && finite_non_negative(irradiance)
                }
                LightKind::Spot { position, direction, intensity, inner_deg, outer_deg } => {
                    position.is_finite()
                        && direction.is_normalized()
                        && finite_non_negative(intensity)
                        && (0.0..90.0).contains(&outer_deg)
                        && (0.0..=outer_deg).contains(&inner_deg)
                }
            };
            if !ok {
                return Err(format!("light {k} `{}`: {:?} at time {t}", l.name, l.at_time(t)));
            }
        }
        Ok(())
    }

    /// Checks the image size, the finiteness of the render settings and the scene bounds.
    fn check_settings(&self) -> Result<(), String> {
        let s = &self.settings;
        if !(1..=16384).contains(&s.width) || !(1..=16384).contains(&s.height) {
            return Err(format!("image size {}x{}", s.width, s.height));
        }
        if !(s.time.is_finite() && s.exposure.is_finite() && s.shadow_filter_radius.is_finite()) {
            return Err("non-finite render settings".to_owned());
        }
        if let Some(b) = &self.bounds {
            if !(b.min.is_finite() && b.max.is_finite() && b.min.cmplt(b.max).all()) {
                return Err(format!("scene bounds {b:?}"));
            }
        }
        Ok(())
    }
}
