//! Wavefront OBJ / MTL loading (through `tobj`) and texture decoding (through `image`).
//!
//! `tobj` reports errors without line numbers and can panic on some malformed MTL lines, so
//! the OBJ text is validated here first (line by line, with line numbers) and the MTL files
//! are parsed here; `tobj` then only does the grouping, triangulation and index
//! de-duplication of input that is known to be well-formed, handed to it in a canonical
//! form (see `Prescan::normalized`) so that it reads each statement the way it was checked.

use super::error::SceneError;
use super::types::{Aabb, Texture, TextureUse};
use glam::{DVec3, Vec2, Vec3};
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
    /// `map_Kd`.
    pub albedo_texture: Option<MtlMap>,
    /// `map_d`.
    pub mask_texture: Option<MtlMap>,
    /// `bump`, `map_bump` or `norm`, with what it is.
    pub bump: Option<(MtlMap, MapKind)>,
    /// `-bm` of the bump statement: multiplies the map's heights (the MTL spec's "bump
    /// multiplier"), so the relief is this times `scene::DEFAULT_RELIEF`.
    pub bump_multiplier: f32,
}

/// A texture statement's resolved, existing file.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MtlMap {
    pub path: PathBuf,
    /// "file.mtl line N" for messages about the texture.
    pub referenced_by: String,
}

/// How a texture file is to be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum MapKind {
    Color,
    Mask,
    Normal,
    Height,
    /// A normal map or a height map, whichever the image looks like.
    Bump,
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
            mask_texture: None,
            bump: None,
            bump_multiplier: 1.0,
        }
    }
}

fn obj_err(path: &Path, line: usize, message: impl std::fmt::Display) -> SceneError {
    SceneError::Obj { path: path.to_path_buf(), message: format!("line {line}: {message}") }
}

fn mtl_err(path: &Path, line: usize, message: impl std::fmt::Display) -> SceneError {
    SceneError::Mtl { path: path.to_path_buf(), message: format!("line {line}: {message}") }
}

/// Parses one number, which must be finite.
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
    /// The text handed to tobj: one line per input line (so line numbers stay the same),
    /// holding only the statements tobj should interpret, in a canonical form (single
    /// spaces, no comments, no vertex colours); everything else is an empty line.
    normalized: String,
}

/// `s` up to an inline comment: a `#` at the start or after white space (a `#` inside a
/// name, as in `usemtl a#1`, stays).
fn strip_comment(s: &str) -> &str {
    let mut prev_space = true;
    for (i, c) in s.char_indices() {
        if c == '#' && prev_space {
            return &s[..i];
        }
        prev_space = c.is_whitespace();
    }
    s
}

/// The values of a statement up to an inline comment.
fn values<'a>(args: &[&'a str]) -> Vec<&'a str> {
    args.iter().copied().take_while(|a| !a.starts_with('#')).collect()
}

/// The material name an empty `usemtl` selects: none defined, so the default material.
pub(crate) const DEFAULT_MATERIAL: &str = "__dvsgi_default_material__";

/// The statements of an OBJ file as (first line number, text, physical lines it spans): any
/// line ending (LF, CRLF or CR alone), and `\` at a line's end joining it to the next.
fn logical_lines(text: &str) -> Vec<(usize, String, usize)> {
    let unified;
    let text = if text.contains('\r') {
        unified = text.replace("\r\n", "\n").replace('\r', "\n");
        &unified
    } else {
        text
    };
    let mut out: Vec<(usize, String, usize)> = Vec::new();
    let mut open = false;
    for (i, line) in text.split('\n').enumerate() {
        let (body, cont) = match line.trim_end().strip_suffix('\\') {
            Some(b) => (b, true),
            None => (line, false),
        };
        match out.last_mut() {
            Some((_, t, n)) if open => {
                t.push(' ');
                t.push_str(body);
                *n += 1;
            }
            _ => out.push((i + 1, body.to_owned(), 1)),
        }
        open = cont;
    }
    out
}

/// What `prescan` counts: OBJ statements, and the vertices, texture coordinates and normals
/// defined so far (what face indices may refer to).
#[derive(Default)]
struct ScanCounts {
    statements: usize,
    v: usize,
    vt: usize,
    vn: usize,
}

/// Validates every line `tobj` would interpret, with line numbers, and builds the canonical
/// text for tobj (see [`Prescan::normalized`]). Keywords are read case-insensitively (`V`,
/// `F` from some exporters); a file with no OBJ statement at all is refused.
fn prescan(path: &Path, text: &str) -> Result<Prescan, SceneError> {
    let mut counts = ScanCounts::default();
    let mut out =
        Prescan { mtllibs: Vec::new(), usemtl: BTreeSet::new(), normalized: String::with_capacity(text.len()) };
    for (i, (ln, raw, spans)) in logical_lines(text).into_iter().enumerate() {
        if i > 0 {
            out.normalized.push('\n');
        }
        prescan_statement(path, ln, &raw, &mut counts, &mut out)?;
        // Lines joined by `\` become empty lines, so line numbers stay the same for tobj.
        (1..spans).for_each(|_| out.normalized.push('\n'));
    }
    if counts.statements == 0 {
        return Err(SceneError::Obj {
            path: path.to_path_buf(),
            message: "no OBJ statement (v, vt, vn, f, o, g, mtllib, usemtl, ...) in the whole file; \
                      is this really a Wavefront OBJ file?"
                .to_owned(),
        });
    }
    Ok(out)
}

/// Checks one statement (line `ln`) and appends its canonical form to `out.normalized`
/// (nothing for a blank line or a statement tobj should not see).
fn prescan_statement(
    path: &Path,
    ln: usize,
    raw: &str,
    counts: &mut ScanCounts,
    out: &mut Prescan,
) -> Result<(), SceneError> {
    let mut words = raw.split_whitespace();
    let Some(word) = words.next() else { return Ok(()) };
    let kw_lower = word.to_ascii_lowercase();
    let kw = kw_lower.as_str();
    let args: Vec<&str> = values(&words.collect::<Vec<_>>());
    // The rest of the line after the keyword (names may contain spaces), up to a comment.
    let rest = strip_comment(&raw.trim_start()[word.len()..]).trim();
    if is_statement(kw) {
        counts.statements += 1;
    }
    let err = |m: String| obj_err(path, ln, m);
    let text = &mut out.normalized;
    match kw {
        "v" => {
            check_position(&args).map_err(err)?;
            // Vertex colours are not used (and tobj refuses files where only some
            // vertices have them).
            emit(text, kw, if args.len() == 6 { &args[..3] } else { &args });
            counts.v += 1;
        }
        "vt" => {
            emit(text, kw, &check_texcoord(&args).map_err(err)?);
            counts.vt += 1;
        }
        "vn" => {
            check_normal(&args).map_err(err)?;
            emit(text, kw, &args);
            counts.vn += 1;
        }
        "f" => {
            check_face(&args, counts).map_err(err)?;
            emit(text, kw, &args);
        }
        "o" | "g" => emit(text, kw, &[rest]),
        "mtllib" => {
            if rest.is_empty() {
                return Err(obj_err(path, ln, "mtllib without a file name"));
            }
            out.mtllibs.push((ln, rest.to_owned()));
            emit(text, kw, &[rest]);
        }
        "usemtl" => {
            // An empty `usemtl` selects the default material, as other loaders do.
            let name = if rest.is_empty() { DEFAULT_MATERIAL } else { rest };
            out.usemtl.insert(name.to_owned());
            emit(text, kw, &[name]);
        }
        // `l` (polylines, which tobj would triangulate), `p`, `s`, comments and anything
        // unknown are left out.
        _ => {}
    }
    Ok(())
}

/// Appends a statement in canonical form: the keyword and its values, single-spaced.
fn emit(text: &mut String, kw: &str, vals: &[&str]) {
    text.push_str(kw);
    for v in vals {
        text.push(' ');
        text.push_str(v);
    }
}

/// Parses every value of a statement, all finite; an error names `what`.
fn parse_all(args: &[&str], what: &str) -> Result<Vec<f32>, String> {
    args.iter().map(|a| parse_finite(a).map_err(|m| format!("{what}: {m}"))).collect()
}

/// Checks a `v` statement's values: x y z, optionally followed by w or by r g b.
fn check_position(args: &[&str]) -> Result<(), String> {
    if !matches!(args.len(), 3 | 4 | 6) {
        return Err(format!(
            "vertex position needs 3 coordinates (optionally followed by w or by r g b), found {} values",
            args.len()
        ));
    }
    let vals = parse_all(args, "vertex position")?;
    if let [x, y, z, w] = vals[..] {
        if w == 0.0 || !(x / w).is_finite() || !(y / w).is_finite() || !(z / w).is_finite() {
            return Err("vertex position: invalid w (zero or too small)".to_owned());
        }
    }
    Ok(())
}

/// Checks a `vt` statement's values and returns the (u, v) handed to tobj.
fn check_texcoord<'a>(args: &[&'a str]) -> Result<[&'a str; 2], String> {
    if !(1..=3).contains(&args.len()) {
        return Err(format!("texture coordinate needs 1 to 3 values (u, optionally v and w), found {}", args.len()));
    }
    parse_all(args, "texture coordinate")?;
    // `vt u` (a 1D texture): v is 0.
    Ok([args[0], args.get(1).copied().unwrap_or("0")])
}

/// Checks a `vn` statement's values: x y z.
fn check_normal(args: &[&str]) -> Result<(), String> {
    if args.len() != 3 {
        return Err(format!("normal needs 3 values (x y z), found {}", args.len()));
    }
    parse_all(args, "normal")?;
    Ok(())
}

/// Checks an `f` statement: at least 3 vertices, each index referring to something defined
/// before this line.
fn check_face(args: &[&str], counts: &ScanCounts) -> Result<(), String> {
    if args.len() < 3 {
        return Err(format!("face needs at least 3 vertices, found {}", args.len()));
    }
    let defined = [(counts.v, "vertex"), (counts.vt, "texture coordinate"), (counts.vn, "normal")];
    for a in args {
        check_face_vertex(a, &defined)?;
    }
    Ok(())
}

/// Checks one face vertex `v`, `v/vt`, `v//vn` or `v/vt/vn` against the (count, noun) of
/// positions, texture coordinates and normals defined so far.
fn check_face_vertex(a: &str, defined: &[(usize, &str); 3]) -> Result<(), String> {
    let parts: Vec<&str> = a.split('/').collect();
    if parts.len() > 3 {
        return Err(format!("face vertex `{a}` has more than 3 `/`-separated indices"));
    }
    for (k, p) in parts.iter().enumerate() {
        if p.is_empty() {
            if k == 0 {
                return Err(format!("face vertex `{a}` has no position index"));
            }
            continue;
        }
        let (count, what) = defined[k];
        check_index(p, count, what)?;
    }
    Ok(())
}

/// Whether `kw` (lower case) is an OBJ statement (interpreted here or not).
fn is_statement(kw: &str) -> bool {
    matches!(
        kw,
        "v" | "vt"
            | "vn"
            | "vp"
            | "f"
            | "l"
            | "p"
            | "o"
            | "g"
            | "s"
            | "mg"
            | "mtllib"
            | "usemtl"
            | "cstype"
            | "deg"
            | "curv"
            | "surf"
    )
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

/// The file name and `-bm` value of a texture statement. Options (`-s 1 1 1`, `-bm 0.5`,
/// `-clamp on` ...) come before the file name, which may contain spaces.
fn map_statement(
    path: &Path,
    ln: usize,
    kw: &str,
    rest: &str,
    args: &[&str],
) -> Result<(String, Option<f32>), SceneError> {
    let mut bm = None;
    let mut i = 0;
    while i < args.len() && args[i].starts_with('-') {
        let values = match args[i] {
            "-blendu" | "-blendv" | "-cc" | "-clamp" | "-imfchan" | "-texres" | "-type" | "-boost" | "-bm" => 1,
            "-mm" => 2,
            "-o" | "-s" | "-t" => args[i + 1..].iter().take(3).take_while(|a| a.parse::<f32>().is_ok()).count(),
            _ => 0,
        };
        if args[i] == "-bm" {
            let v = args.get(i + 1).map(|a| parse_finite(a)).transpose();
            bm = v.map_err(|m| mtl_err(path, ln, format!("{kw} -bm: {m}")))?;
        }
        i += 1 + values;
    }
    let name = if i == 0 { rest.to_owned() } else { args[i.min(args.len())..].join(" ") };
    if name.is_empty() {
        return Err(mtl_err(path, ln, format!("{kw} without a file name")));
    }
    Ok((name, bm))
}

/// Resolves a texture statement's file. A missing texture is common in downloaded models: it
/// is warned about and the material goes without that map (`None`).
fn find_map(path: &Path, ln: usize, kw: &str, name: &str, material: &str) -> Result<Option<PathBuf>, SceneError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let (found, tried) = find_relative(dir, name);
    if found.is_some() {
        return Ok(found);
    }
    if let Some(d) = tried.iter().find(|p| super::text::exists(p)) {
        return Err(mtl_err(path, ln, format!("{kw} `{name}`: {} exists but is not a file", d.display())));
    }
    let without = if kw == "map_Kd" { "its untextured Kd colour" } else { "that map" };
    log::warn!(
        "{}: line {ln}: texture `{name}` ({kw} of material `{material}`) not found; looked at {}; \
         the material goes without {without}",
        path.display(),
        join_paths(&tried)
    );
    Ok(None)
}

fn join_paths(v: &[PathBuf]) -> String {
    v.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
}

/// A colour statement's value: r g b, or one number for all three; finite and >= 0. `args`
/// stop at an inline comment ("Kd 1 0 0 # red"), as [`values`] gives them.
fn parse_color(path: &Path, ln: usize, key: &str, args: &[&str]) -> Result<Vec3, SceneError> {
    let vals = parse_all(args, key).map_err(|m| mtl_err(path, ln, m))?;
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

fn read_mtl(path: &Path) -> Result<String, SceneError> {
    super::text::read(path, &super::text::MTL_FILE, |p, message| SceneError::Mtl { path: p.to_path_buf(), message })
}

/// Parses an MTL file. Unknown statements are ignored; colours must be finite and >= 0.
pub(crate) fn parse_mtl(path: &Path, text: &str) -> Result<Vec<MtlMaterial>, SceneError> {
    let fname = path.display().to_string();
    let mut mats: Vec<MtlMaterial> = Vec::new();
    for (ln, raw, _) in logical_lines(text) {
        let line = raw.trim();
        let mut words = line.split_whitespace();
        let Some(kw) = words.next() else { continue };
        if kw.starts_with('#') {
            continue;
        }
        // Values stop at an inline comment.
        let args: Vec<&str> = values(&words.collect::<Vec<_>>());
        let rest = strip_comment(&line[kw.len()..]).trim();
        if kw == "newmtl" {
            if rest.is_empty() {
                return Err(mtl_err(path, ln, "newmtl without a material name"));
            }
            mats.push(MtlMaterial::new(rest.to_owned()));
            continue;
        }
        if !matches!(kw, "Kd" | "Ks" | "Ke" | "Ns" | "map_Kd" | "map_d" | "map_bump" | "bump" | "norm") {
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
            "map_Kd" | "map_d" | "map_bump" | "bump" | "norm" => {
                let (name, bm) = map_statement(path, ln, kw, rest, &args)?;
                let Some(found) = find_map(path, ln, kw, &name, &cur.name)? else { continue };
                let map = MtlMap { path: found, referenced_by: format!("{fname} line {ln}") };
                match kw {
                    "map_Kd" => cur.albedo_texture = Some(map),
                    "map_d" => cur.mask_texture = Some(map),
                    // `bump` and `map_bump` name a height map or (CryEngine, many exporters) a
                    // normal map: decided by the image at load. `norm` is a normal map.
                    _ => {
                        cur.bump = Some((map, if kw == "norm" { MapKind::Normal } else { MapKind::Bump }));
                        cur.bump_multiplier = bm.unwrap_or(cur.bump_multiplier);
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
    let text = super::text::read(path, &super::text::OBJ_FILE, |p, message| SceneError::Obj {
        path: p.to_path_buf(),
        message,
    })?;
    let scan = prescan(path, &text)?;
    let libs = load_mtllibs(path, &scan.mtllibs)?;
    warn_unknown_materials(path, &scan, &libs);
    let models = parse_with_tobj(path, &scan.normalized, &libs.for_tobj)?;
    let mut groups = Vec::new();
    for model in models {
        if let Some(group) = obj_group(path, model, libs.materials.len())? {
            groups.push(group);
        }
    }
    Ok(ObjData { groups, materials: libs.materials })
}

/// The material libraries of an OBJ file.
struct MtlLibs {
    /// The materials of all libraries, in file order.
    materials: Vec<MtlMaterial>,
    /// What tobj gets for each `mtllib`, in the order it asks for them.
    for_tobj: Vec<tobj::MTLLoadResult>,
    /// Some library was not found (and was warned about).
    missing: bool,
}

/// Reads and parses every `mtllib` (line, name); a missing library is warned about and
/// contributes no materials.
fn load_mtllibs(path: &Path, mtllibs: &[(usize, String)]) -> Result<MtlLibs, SceneError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut libs = MtlLibs { materials: Vec::new(), for_tobj: Vec::new(), missing: false };
    for (ln, name) in mtllibs {
        let Some(mats) = load_mtllib(path, dir, *ln, name)? else {
            libs.for_tobj.push(Ok((Vec::new(), Default::default())));
            libs.missing = true;
            continue;
        };
        let map = mats.iter().enumerate().map(|(k, m)| (m.name.clone(), k)).collect();
        let tmats = mats.iter().map(|m| tobj::Material { name: m.name.clone(), ..Default::default() }).collect();
        libs.for_tobj.push(Ok((tmats, map)));
        libs.materials.extend(mats);
    }
    Ok(libs)
}

/// The materials of the library `name` (named on line `ln` of `path`, relative to `dir`), or
/// `None` (warned about) where it is not found.
fn load_mtllib(path: &Path, dir: &Path, ln: usize, name: &str) -> Result<Option<Vec<MtlMaterial>>, SceneError> {
    let (found, tried) = find_relative(dir, name);
    let Some(mtl_path) = found else {
        if let Some(there) = tried.iter().find(|p| super::text::exists(p)) {
            // It is there but no regular file: say what it is, not "not found".
            super::text::check_regular(there, super::text::MAX_ASSET_BYTES)?;
        }
        // A missing library is common in downloaded models: warn, and its materials fall
        // back to the default (as other loaders do).
        log::warn!(
            "{}: line {ln}: material library `{name}` not found (looked at {}); its materials use the default",
            path.display(),
            join_paths(&tried)
        );
        return Ok(None);
    };
    Ok(Some(parse_mtl(&mtl_path, &read_mtl(&mtl_path)?)?))
}

/// Warns about `usemtl` names no library defines (unless a library was missing, which was
/// already said).
fn warn_unknown_materials(path: &Path, scan: &Prescan, libs: &MtlLibs) {
    let known: BTreeSet<&str> = libs.materials.iter().map(|m| m.name.as_str()).collect();
    let named: Vec<&String> = scan.usemtl.iter().filter(|u| u.as_str() != DEFAULT_MATERIAL).collect();
    if libs.missing {
        // Already said.
    } else if scan.mtllibs.is_empty() && !named.is_empty() {
        log::warn!(
            "{}: uses materials ({}) but has no mtllib; they fall back to the scene's material or the default",
            path.display(),
            named.iter().map(|u| u.as_str()).collect::<Vec<_>>().join(", ")
        );
    } else {
        for u in named {
            if !known.contains(u.as_str()) {
                log::warn!(
                    "{}: usemtl `{u}` is not defined in its material library; using the default material",
                    path.display()
                );
            }
        }
    }
}

/// Hands the canonical OBJ text to tobj, which groups it and de-duplicates indices; `libs`
/// answers its `mtllib` requests in order.
fn parse_with_tobj(path: &Path, text: &str, libs: &[tobj::MTLLoadResult]) -> Result<Vec<tobj::Model>, SceneError> {
    let next = Cell::new(0usize);
    // `..Default::default()` covers fields that exist only with some tobj features.
    #[allow(clippy::needless_update)]
    // Faces come as polygons (face_arities) and are ear-clipped here: tobj's fan fills
    // concave faces in.
    let opts = tobj::LoadOptions {
        triangulate: false,
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
    Ok(models)
}

/// Turns a tobj model into a triangulated group with unit normals; `None` for a model
/// without faces. A material id of `n_materials` or more becomes `None`.
fn obj_group(path: &Path, model: tobj::Model, n_materials: usize) -> Result<Option<ObjGroup>, SceneError> {
    let m = model.mesh;
    if m.indices.is_empty() {
        return Ok(None);
    }
    let err = |message: String| SceneError::Obj {
        path: path.to_path_buf(),
        message: format!("group `{}`: {message}", model.name),
    };
    let n = m.positions.len() / 3;
    let positions: Vec<Vec3> = m.positions.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    if let Some(p) = positions.iter().find(|p| !p.is_finite()) {
        return Err(err(format!("non-finite vertex position {p}")));
    }
    let indices = super::triangulate::triangulate_faces(&positions, &m.indices, &m.face_arities);
    if indices.len() % 3 != 0 {
        return Err(err("index count is not a multiple of 3".to_owned()));
    }
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
        return Err(err(format!("vertex index {bad} out of range ({n} vertices)")));
    }
    let uvs = group_uvs(path, &model.name, &m.texcoords, n);
    let normals = group_normals(path, &model.name, &m.normals, n);
    let (positions, normals, uvs, indices) = finish_normals(positions, normals, uvs, indices);
    let mut bounds = Aabb::EMPTY;
    for p in &positions {
        bounds.grow(*p);
    }
    let material = m.material_id.filter(|&id| id < n_materials);
    Ok(Some(ObjGroup { name: model.name, positions, normals, uvs, indices, material, bounds }))
}

/// The `n` texture coordinates of group `name`, v flipped to a top-left origin; zeros (with a
/// warning where only some vertices have them) unless every vertex has one.
fn group_uvs(path: &Path, name: &str, texcoords: &[f32], n: usize) -> Vec<Vec2> {
    if texcoords.len() == 2 * n {
        return texcoords.chunks_exact(2).map(|c| Vec2::new(c[0], 1.0 - c[1])).collect();
    }
    if !texcoords.is_empty() {
        log::warn!("{}: group `{name}` has texture coordinates on only some vertices; using zeros", path.display());
    }
    vec![Vec2::ZERO; n]
}

/// The `n` normals of group `name`, or `None` (to be generated; with a warning where only
/// some vertices have them) unless every vertex has one.
fn group_normals(path: &Path, name: &str, normals: &[f32], n: usize) -> Option<Vec<Vec3>> {
    if normals.len() == 3 * n {
        return Some(normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect());
    }
    if !normals.is_empty() {
        log::warn!("{}: group `{name}` has normals on only some vertices; generating smooth normals", path.display());
    }
    None
}

/// Area-weighted face normals, in f64 so that edges of huge (but finite) coordinates do not
/// overflow and tiny triangles do not underflow.
fn face_normals(positions: &[Vec3], indices: &[u32]) -> Vec<DVec3> {
    indices
        .chunks_exact(3)
        .map(|t| {
            let p = |k: usize| positions.get(t[k] as usize).copied().unwrap_or(Vec3::ZERO).as_dvec3();
            (p(1) - p(0)).cross(p(2) - p(0))
        })
        .collect()
}

/// `v` scaled to unit length (as f32), or `None` for a zero or non-finite vector.
fn unit(v: DVec3) -> Option<Vec3> {
    let l = v.length();
    if l.is_finite() && l > 0.0 {
        let u = (v / l).as_vec3();
        u.is_finite().then_some(u)
    } else {
        None
    }
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
/// a crease angle, splitting vertices where a vertex needs more than one normal. Every normal
/// that comes out is finite and of unit length: a zero normal is replaced by the (area
/// weighted) normal of the adjacent faces, and where those are degenerate too by +Y.
fn finish_normals(
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Vec<Vec2>,
    indices: Vec<u32>,
) -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<u32>) {
    let n = positions.len();
    let fnorm = face_normals(&positions, &indices);
    let (start, tris) = adjacency(n, &indices);
    let adjacent_sum = |v: usize| -> DVec3 {
        let (a, b) = (start[v], start[v + 1]);
        tris[a..b].iter().map(|&t| fnorm[t as usize]).sum::<DVec3>()
    };

    if let Some(mut normals) = normals {
        for (v, nrm) in normals.iter_mut().enumerate() {
            *nrm = unit(nrm.as_dvec3()).or_else(|| unit(adjacent_sum(v))).unwrap_or(Vec3::Y);
        }
        return (positions, normals, uvs, indices);
    }

    let cos_crease = CREASE_ANGLE_DEG.to_radians().cos();
    let funit: Vec<Vec3> = fnorm.iter().map(|f| unit(*f).unwrap_or(Vec3::ZERO)).collect();
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
        let mut sum = DVec3::ZERO;
        for &g in &tris[a..b] {
            if funit[g as usize].dot(own) >= cos_crease {
                sum += fnorm[g as usize];
            }
        }
        let nrm = unit(sum)
            .or_else(|| (own != Vec3::ZERO).then_some(own))
            .or_else(|| unit(adjacent_sum(v)))
            .unwrap_or(Vec3::Y);
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

/// Decodes an image file to RGBA8 in the encoding `kind` asks for (colour stays sRGB-encoded;
/// normal maps in the DirectX convention, `y_down`, are turned to the OpenGL one).
/// `referenced_by` names the file (and line) that asked for it.
pub(crate) fn load_texture(
    path: &Path,
    referenced_by: &str,
    kind: MapKind,
    y_down: bool,
) -> Result<Texture, SceneError> {
    let err = |message: String| SceneError::Texture { path: path.to_path_buf(), message };
    super::text::check_regular(path, super::text::MAX_ASSET_BYTES)?;
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
    let rgba8 = rgba.into_raw();
    let usage = match kind {
        MapKind::Color => TextureUse::Color,
        MapKind::Mask => TextureUse::Mask,
        MapKind::Normal => TextureUse::Normal,
        MapKind::Height => TextureUse::Height,
        MapKind::Bump => super::maps::bump_use(&rgba8),
    };
    let rgba8 = super::maps::encode_for(usage, rgba8, y_down);
    Ok(Texture { path: path.to_path_buf(), width, height, rgba8, usage })
}
