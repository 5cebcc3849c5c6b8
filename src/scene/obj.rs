//! Wavefront OBJ / MTL loading (through `tobj`) and texture decoding (through `image`).
//!
//! `tobj` reports errors without line numbers and can panic on some malformed MTL lines, so
//! the OBJ text is validated here first (line by line, with line numbers) and the MTL files
//! are parsed here; `tobj` then only does the grouping, triangulation and index
//! de-duplication of input that is known to be well-formed.

use super::error::SceneError;
use super::types::{Aabb, Texture};
use glam::{Vec2, Vec3};
use std::cell::Cell;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Smooth normals are only averaged across faces whose normals differ by less than this.
const CREASE_ANGLE_DEG: f32 = 60.0;

/// A loaded OBJ file.
#[derive(Debug, Clone)]
pub(crate) struct ObjData {
    /// One entry per tobj model (`o`/`g` group, split further where `usemtl` changes) that
    /// has at least one triangle.
    pub groups: Vec<ObjGroup>,
    /// Materials of all `mtllib`s, in file order; `ObjGroup::material` indexes this.
    pub materials: Vec<MtlMaterial>,
}

#[derive(Debug, Clone)]
pub(crate) struct ObjGroup {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Top-left origin (v flipped from the OBJ convention), so `v = 0` is the first texel row.
    pub uvs: Vec<Vec2>,
    pub indices: Vec<u32>,
    /// Index into `ObjData::materials`; `None` = no (known) material.
    pub material: Option<usize>,
    pub bounds: Aabb,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MtlMaterial {
    pub name: String,
    pub albedo: Vec3,
    pub specular: Vec3,
    pub shininess: f32,
    pub emission: Vec3,
    /// Resolved, existing path of `map_Kd`.
    pub albedo_texture: Option<PathBuf>,
    /// "file.mtl line N" for messages about the texture.
    pub texture_ref: String,
}

impl MtlMaterial {
    fn new(name: String) -> Self {
        MtlMaterial {
            name,
            albedo: Vec3::splat(0.8),
            specular: Vec3::ZERO,
            shininess: 1.0,
            emission: Vec3::ZERO,
            albedo_texture: None,
            texture_ref: String::new(),
        }
    }
}

fn obj_err(path: &Path, line: usize, message: impl std::fmt::Display) -> SceneError {
    SceneError::Obj { path: path.to_path_buf(), message: format!("line {line}: {message}") }
}

fn mtl_err(path: &Path, line: usize, message: impl std::fmt::Display) -> SceneError {
    SceneError::Mtl { path: path.to_path_buf(), message: format!("line {line}: {message}") }
}

/// Parses `n` numbers, all finite.
fn parse_finite(tok: &str) -> Result<f32, String> {
    match tok.parse::<f32>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(format!("`{tok}` is not a finite number (NaN and infinity are not allowed)")),
        Err(_) => Err(format!("`{tok}` is not a number")),
    }
}

/// Resolves one face-vertex index element (1-based, or negative = relative) against `count`.
fn check_index(tok: &str, count: usize, what: &str) -> Result<(), String> {
    let i: i64 = tok.parse().map_err(|_| format!("face index `{tok}` is not an integer"))?;
    if i == 0 {
        return Err(format!("face {what} index 0 is invalid (OBJ indices start at 1)"));
    }
    let ok = if i > 0 { (i as u64) <= count as u64 } else { i.unsigned_abs() <= count as u64 };
    if ok {
        Ok(())
    } else {
        let noun = match (count, what) {
            (1, _) => format!("{what} is"),
            (_, "vertex") => "vertices are".to_owned(),
            _ => format!("{what}s are"),
        };
        Err(format!("face refers to {what} {i} but only {count} {noun} defined before this line"))
    }
}

struct Prescan {
    mtllibs: Vec<(usize, String)>,
    usemtl: BTreeSet<String>,
    /// `l` lines, which tobj would turn into triangles; they are blanked out.
    line_elements: Vec<usize>,
}

/// Validates every line `tobj` would interpret, with line numbers.
fn prescan(path: &Path, text: &str) -> Result<Prescan, SceneError> {
    let (mut nv, mut nvt, mut nvn) = (0usize, 0usize, 0usize);
    let mut out = Prescan { mtllibs: Vec::new(), usemtl: BTreeSet::new(), line_elements: Vec::new() };
    for (i, raw) in text.lines().enumerate() {
        let ln = i + 1;
        let mut words = raw.split_whitespace();
        let Some(kw) = words.next() else { continue };
        let args: Vec<&str> = words.collect();
        match kw {
            "v" => {
                if !matches!(args.len(), 3 | 4 | 6) {
                    return Err(obj_err(
                        path,
                        ln,
                        format!(
                            "vertex position needs 3 coordinates (optionally followed by w or by r g b), found {} values",
                            args.len()
                        ),
                    ));
                }
                let mut vals = Vec::with_capacity(args.len());
                for a in &args {
                    vals.push(parse_finite(a).map_err(|m| obj_err(path, ln, format!("vertex position: {m}")))?);
                }
                if args.len() == 4 {
                    let w = vals[3];
                    if w == 0.0
                        || !(vals[0] / w).is_finite()
                        || !(vals[1] / w).is_finite()
                        || !(vals[2] / w).is_finite()
                    {
                        return Err(obj_err(path, ln, "vertex position: invalid w (zero or too small)"));
                    }
                }
                nv += 1;
            }
            "vt" => {
                if args.len() < 2 {
                    return Err(obj_err(path, ln, "texture coordinate needs at least 2 values (u v)"));
                }
                for a in args.iter().take(2) {
                    parse_finite(a).map_err(|m| obj_err(path, ln, format!("texture coordinate: {m}")))?;
                }
                nvt += 1;
            }
            "vn" => {
                if args.len() < 3 {
                    return Err(obj_err(path, ln, "normal needs 3 values (x y z)"));
                }
                for a in args.iter().take(3) {
                    parse_finite(a).map_err(|m| obj_err(path, ln, format!("normal: {m}")))?;
                }
                nvn += 1;
            }
            "f" => {
                if args.len() < 3 {
                    return Err(obj_err(path, ln, format!("face needs at least 3 vertices, found {}", args.len())));
                }
                for a in &args {
                    let parts: Vec<&str> = a.split('/').collect();
                    if parts.len() > 3 {
                        return Err(obj_err(
                            path,
                            ln,
                            format!("face vertex `{a}` has more than 3 `/`-separated indices"),
                        ));
                    }
                    let counts = [(nv, "vertex"), (nvt, "texture coordinate"), (nvn, "normal")];
                    for (k, p) in parts.iter().enumerate() {
                        if p.is_empty() {
                            if k == 0 {
                                return Err(obj_err(path, ln, format!("face vertex `{a}` has no position index")));
                            }
                            continue;
                        }
                        let (count, what) = counts[k];
                        check_index(p, count, what).map_err(|m| obj_err(path, ln, m))?;
                    }
                }
            }
            "l" => out.line_elements.push(i),
            "mtllib" => {
                let rest = raw.trim_start()[kw.len()..].trim();
                if rest.is_empty() {
                    return Err(obj_err(path, ln, "mtllib without a file name"));
                }
                out.mtllibs.push((ln, rest.to_owned()));
            }
            "usemtl" => {
                let rest = raw.trim_start()[kw.len()..].trim();
                if rest.is_empty() {
                    return Err(obj_err(path, ln, "usemtl without a material name"));
                }
                out.usemtl.insert(rest.to_owned());
            }
            _ => {}
        }
    }
    Ok(out)
}

/// Tries `name` relative to `dir`, also with Windows separators turned into `/`.
fn find_relative(dir: &Path, name: &str) -> (Option<PathBuf>, Vec<PathBuf>) {
    let mut tried = Vec::new();
    let mut cands = vec![name.to_owned()];
    if name.contains('\\') {
        cands.push(name.replace('\\', "/"));
    }
    for c in cands {
        let p = Path::new(&c);
        let full = if p.is_absolute() { p.to_path_buf() } else { dir.join(p) };
        if full.is_file() {
            return (Some(full), tried);
        }
        tried.push(full);
    }
    (None, tried)
}

fn join_paths(v: &[PathBuf]) -> String {
    v.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
}

fn read_text(path: &Path) -> Result<String, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io { path: path.to_path_buf(), source })?;
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
    })
}

fn parse_color(path: &Path, ln: usize, key: &str, args: &[&str]) -> Result<Vec3, SceneError> {
    // Inline comments ("Kd 1 0 0 # red") are allowed.
    let args: Vec<&str> = args.iter().copied().take_while(|a| !a.starts_with('#')).collect();
    let vals = args
        .iter()
        .map(|a| parse_finite(a))
        .collect::<Result<Vec<f32>, String>>()
        .map_err(|m| mtl_err(path, ln, format!("{key}: {m}")))?;
    let c = match vals.as_slice() {
        [r] => Vec3::splat(*r),
        [r, g, b] => Vec3::new(*r, *g, *b),
        _ => {
            return Err(mtl_err(
                path,
                ln,
                format!(
                    "{key} needs 3 numbers (r g b) or 1, found {} (spectral/xyz colours are not supported)",
                    vals.len()
                ),
            ))
        }
    };
    if c.min_element() < 0.0 {
        return Err(mtl_err(path, ln, format!("{key} must not be negative")));
    }
    Ok(c)
}

/// Parses an MTL file. Unknown statements are ignored; colours must be finite and >= 0.
pub(crate) fn parse_mtl(path: &Path, text: &str) -> Result<Vec<MtlMaterial>, SceneError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let fname = path.display().to_string();
    let mut mats: Vec<MtlMaterial> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let ln = i + 1;
        let line = raw.trim();
        let mut words = line.split_whitespace();
        let Some(kw) = words.next() else { continue };
        if kw.starts_with('#') {
            continue;
        }
        let args: Vec<&str> = words.collect();
        let rest = line[kw.len()..].trim();
        if kw == "newmtl" {
            if rest.is_empty() {
                return Err(mtl_err(path, ln, "newmtl without a material name"));
            }
            mats.push(MtlMaterial::new(rest.to_owned()));
            continue;
        }
        if !matches!(kw, "Kd" | "Ks" | "Ke" | "Ns" | "map_Kd") {
            continue;
        }
        let Some(cur) = mats.last_mut() else {
            log::warn!("{fname}: line {ln}: `{kw}` before any `newmtl`; ignored");
            continue;
        };
        match kw {
            "Kd" => cur.albedo = parse_color(path, ln, kw, &args)?,
            "Ks" => cur.specular = parse_color(path, ln, kw, &args)?,
            "Ke" => cur.emission = parse_color(path, ln, kw, &args)?,
            "Ns" => {
                let Some(a) = args.first() else {
                    return Err(mtl_err(path, ln, "Ns needs a number"));
                };
                let n = parse_finite(a).map_err(|m| mtl_err(path, ln, format!("Ns: {m}")))?;
                if n < 0.0 {
                    return Err(mtl_err(path, ln, "Ns (shininess) must not be negative"));
                }
                cur.shininess = n;
            }
            "map_Kd" => {
                // Options (-s 1 1 1, -bm 0.5, ...) come before the file name.
                let name = if rest.starts_with('-') { args.last().copied().unwrap_or("") } else { rest };
                if name.is_empty() {
                    return Err(mtl_err(path, ln, "map_Kd without a file name"));
                }
                let (found, tried) = find_relative(dir, name);
                match found {
                    Some(p) => {
                        cur.albedo_texture = Some(p);
                        cur.texture_ref = format!("{fname} line {ln}");
                    }
                    None => {
                        return Err(SceneError::Texture {
                            path: tried.first().cloned().unwrap_or_else(|| dir.join(name)),
                            message: format!(
                                "texture not found (referenced by map_Kd `{name}` in {fname} line {ln}; looked at {})",
                                join_paths(&tried)
                            ),
                        })
                    }
                }
            }
            _ => {}
        }
    }
    Ok(mats)
}

/// Loads an OBJ file with its MTL libraries.
pub(crate) fn load_obj(path: &Path) -> Result<ObjData, SceneError> {
    let text = read_text(path)?;
    let scan = prescan(path, &text)?;
    let dir = path.parent().unwrap_or(Path::new("."));

    // Material libraries, in the order tobj will ask for them.
    let mut materials: Vec<MtlMaterial> = Vec::new();
    let mut libs: Vec<tobj::MTLLoadResult> = Vec::new();
    for (ln, name) in &scan.mtllibs {
        let (found, tried) = find_relative(dir, name);
        let Some(mtl_path) = found else {
            return Err(SceneError::Mtl {
                path: tried.first().cloned().unwrap_or_else(|| dir.join(name)),
                message: format!(
                    "material library not found (referenced by `mtllib {name}` in {} line {ln}; looked at {})",
                    path.display(),
                    join_paths(&tried)
                ),
            });
        };
        let mats = parse_mtl(&mtl_path, &read_text(&mtl_path)?)?;
        let map = mats.iter().enumerate().map(|(k, m)| (m.name.clone(), k)).collect();
        let tmats = mats.iter().map(|m| tobj::Material { name: m.name.clone(), ..Default::default() }).collect();
        libs.push(Ok((tmats, map)));
        materials.extend(mats);
    }
    let known: BTreeSet<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    if scan.mtllibs.is_empty() && !scan.usemtl.is_empty() {
        log::warn!(
            "{}: uses materials ({}) but has no mtllib; they fall back to the scene's material or the default",
            path.display(),
            scan.usemtl.iter().cloned().collect::<Vec<_>>().join(", ")
        );
    } else {
        for u in &scan.usemtl {
            if !known.contains(u.as_str()) {
                log::warn!(
                    "{}: usemtl `{u}` is not defined in its material library; using the default material",
                    path.display()
                );
            }
        }
    }

    // Blank out `l` elements (tobj would triangulate polylines); keeps the line numbering.
    let text = if scan.line_elements.is_empty() {
        text
    } else {
        let drop: BTreeSet<usize> = scan.line_elements.iter().copied().collect();
        text.lines().enumerate().map(|(i, l)| if drop.contains(&i) { "" } else { l }).collect::<Vec<_>>().join("\n")
    };

    let next = Cell::new(0usize);
    // `..Default::default()` covers fields that exist only with some tobj features.
    #[allow(clippy::needless_update)]
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_p| {
        let k = next.get();
        next.set(k + 1);
        match libs.get(k) {
            Some(Ok((m, map))) => Ok((m.clone(), map.clone())),
            _ => Err(tobj::LoadError::OpenFileFailed),
        }
    })
    .map_err(|e| SceneError::Obj { path: path.to_path_buf(), message: format!("cannot parse OBJ: {e}") })?;

    let mut groups = Vec::new();
    for model in models {
        let m = model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let n = m.positions.len() / 3;
        let positions: Vec<Vec3> = m.positions.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        if let Some(p) = positions.iter().find(|p| !p.is_finite()) {
            return Err(SceneError::Obj {
                path: path.to_path_buf(),
                message: format!("group `{}`: non-finite vertex position {p}", model.name),
            });
        }
        if m.indices.len() % 3 != 0 {
            return Err(SceneError::Obj {
                path: path.to_path_buf(),
                message: format!("group `{}`: index count is not a multiple of 3", model.name),
            });
        }
        if let Some(bad) = m.indices.iter().find(|&&i| i as usize >= n) {
            return Err(SceneError::Obj {
                path: path.to_path_buf(),
                message: format!("group `{}`: vertex index {bad} out of range ({n} vertices)", model.name),
            });
        }
        let uvs: Vec<Vec2> = if m.texcoords.len() == 2 * n {
            m.texcoords.chunks_exact(2).map(|c| Vec2::new(c[0], 1.0 - c[1])).collect()
        } else {
            if !m.texcoords.is_empty() {
                log::warn!(
                    "{}: group `{}` has texture coordinates on only some vertices; using zeros",
                    path.display(),
                    model.name
                );
            }
            vec![Vec2::ZERO; n]
        };
        let normals = if m.normals.len() == 3 * n {
            Some(m.normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect::<Vec<_>>())
        } else {
            if !m.normals.is_empty() {
                log::warn!(
                    "{}: group `{}` has normals on only some vertices; generating smooth normals",
                    path.display(),
                    model.name
                );
            }
            None
        };
        let (positions, normals, uvs, indices) = finish_normals(positions, normals, uvs, m.indices);
        let mut bounds = Aabb::EMPTY;
        for p in &positions {
            bounds.grow(*p);
        }
        let material = m.material_id.filter(|&id| id < materials.len());
        groups.push(ObjGroup { name: model.name, positions, normals, uvs, indices, material, bounds });
    }
    Ok(ObjData { groups, materials })
}

fn face_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    indices
        .chunks_exact(3)
        .map(|t| {
            let p = |k: usize| positions.get(t[k] as usize).copied().unwrap_or(Vec3::ZERO);
            (p(1) - p(0)).cross(p(2) - p(0))
        })
        .collect()
}

/// Vertex -> adjacent triangles, as (offsets, triangle list).
fn adjacency(n: usize, indices: &[u32]) -> (Vec<usize>, Vec<u32>) {
    let mut start = vec![0usize; n + 1];
    for &i in indices {
        if let Some(s) = start.get_mut(i as usize + 1) {
            *s += 1;
        }
    }
    for k in 0..n {
        start[k + 1] += start[k];
    }
    let mut fill = start.clone();
    let mut tris = vec![0u32; indices.len()];
    for (c, &i) in indices.iter().enumerate() {
        if let Some(f) = fill.get_mut(i as usize) {
            tris[*f] = (c / 3) as u32;
            *f += 1;
        }
    }
    (start, tris)
}

/// Normalises given normals (repairing zero/non-finite ones) or generates smooth normals with
/// a crease angle, splitting vertices where a vertex needs more than one normal.
fn finish_normals(
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Vec<Vec2>,
    indices: Vec<u32>,
) -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<u32>) {
    let n = positions.len();
    let fnorm = face_normals(&positions, &indices);
    let (start, tris) = adjacency(n, &indices);
    let adjacent_sum = |v: usize| -> Vec3 {
        let (a, b) = (start[v], start[v + 1]);
        tris[a..b].iter().map(|&t| fnorm[t as usize]).sum::<Vec3>()
    };

    if let Some(mut normals) = normals {
        for (v, nrm) in normals.iter_mut().enumerate() {
            let u = if nrm.is_finite() { nrm.normalize_or_zero() } else { Vec3::ZERO };
            *nrm = if u != Vec3::ZERO {
                u
            } else {
                let s = adjacent_sum(v).normalize_or_zero();
                if s != Vec3::ZERO && s.is_finite() {
                    s
                } else {
                    Vec3::Y
                }
            };
        }
        return (positions, normals, uvs, indices);
    }

    let cos_crease = CREASE_ANGLE_DEG.to_radians().cos();
    let funit: Vec<Vec3> = fnorm
        .iter()
        .map(|f| {
            let u = f.normalize_or_zero();
            if u.is_finite() {
                u
            } else {
                Vec3::ZERO
            }
        })
        .collect();
    let mut out_pos = Vec::with_capacity(n);
    let mut out_nrm = Vec::with_capacity(n);
    let mut out_uv = Vec::with_capacity(n);
    // Per original vertex: the (normal, new index) pairs made so far.
    let mut made: Vec<Vec<(Vec3, u32)>> = vec![Vec::new(); n];
    let mut out_idx = Vec::with_capacity(indices.len());
    for (c, &vi) in indices.iter().enumerate() {
        let v = vi as usize;
        let t = c / 3;
        let own = funit[t];
        let (a, b) = (start[v], start[v + 1]);
        let mut sum = Vec3::ZERO;
        for &g in &tris[a..b] {
            if funit[g as usize].dot(own) >= cos_crease {
                sum += fnorm[g as usize];
            }
        }
        let mut nrm = sum.normalize_or_zero();
        if nrm == Vec3::ZERO || !nrm.is_finite() {
            nrm = own;
        }
        if nrm == Vec3::ZERO {
            nrm = adjacent_sum(v).normalize_or_zero();
        }
        if nrm == Vec3::ZERO || !nrm.is_finite() {
            nrm = Vec3::Y;
        }
        let slot = &mut made[v];
        let idx = match slot.iter().find(|(m, _)| *m == nrm) {
            Some(&(_, k)) => k,
            None => {
                let k = out_pos.len() as u32;
                out_pos.push(positions[v]);
                out_nrm.push(nrm);
                out_uv.push(uvs.get(v).copied().unwrap_or(Vec2::ZERO));
                slot.push((nrm, k));
                k
            }
        };
        out_idx.push(idx);
    }
    (out_pos, out_nrm, out_uv, out_idx)
}

/// Decodes an image file to RGBA8 (kept sRGB-encoded). `referenced_by` names the file (and
/// line) that asked for it.
pub(crate) fn load_texture(path: &Path, referenced_by: &str) -> Result<Texture, SceneError> {
    let err = |message: String| SceneError::Texture { path: path.to_path_buf(), message };
    let reader = image::ImageReader::open(path)
        .map_err(|e| err(format!("cannot read texture (referenced by {referenced_by}): {e}")))?
        .with_guessed_format()
        .map_err(|e| err(format!("cannot read texture (referenced by {referenced_by}): {e}")))?;
    let img = reader.decode().map_err(|e| {
        err(format!(
            "cannot decode texture (referenced by {referenced_by}): {e}; use a valid PNG, JPEG, TGA, BMP or EXR file"
        ))
    })?;
    let rgba = img.to_rgba8();
    let (width, height) = rgba.dimensions();
    if width == 0 || height == 0 {
        return Err(err(format!("texture has zero size (referenced by {referenced_by})")));
    }
    Ok(Texture { path: path.to_path_buf(), width, height, rgba8: rgba.into_raw() })
}
