//! Quality presets (`--preset`): points on the measured speed/accuracy frontier of the
//! Cornell box and Sponza on lavapipe (ACCURACY.md says how each was chosen and what it
//! costs and scores). A preset sets `[gi]` keys; `--set` overrides still apply after it.

/// A named set of `[gi]` settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    Low,
    Medium,
    High,
    Ultra,
    /// Above the default: quadrant footprints for the pixels' cones, two-tap cone samples and
    /// per-side voxel light, the most accurate cone setting on both fronts, at about twice
    /// `ultra`'s frame in lavapipe's sweeps (small images: the pixels' cones are most of its
    /// cost on large ones).
    Max,
}

impl Preset {
    /// The `[gi]` overrides, as (dotted key, TOML value).
    pub fn overrides(self) -> Vec<(String, String)> {
        // (voxels, cones, bounces, downsample): points on the FLIP fronts of the Cornell box
        // and Sponza on lavapipe, re-measured with 16 cones (issue 43, ACCURACY.md "Presets");
        // `ultra` is the scene-file default (on the Cornell box's front). Step 0.5, automatic
        // apertures, AO off, and the bounce gathered by one in 4 static voxels per update
        // everywhere. The voxel light's attenuation: the mean normal's cosine, exact for a
        // voxel one plane crosses, except at 64^3, where most of Sponza's voxels hold several
        // faces: the cosine of their mean normal misses the lit faces' light, which the
        // per-axis rule (their average, for faces along the axes) keeps (Sponza's FLIP 0.175
        // against 0.200 with `medium`, ACCURACY.md). `max` keeps a transmittance per quarter of
        // each cone's footprint and gives a voxel's sides the light of the faces each sees: at
        // 128^3 the top of both fronts (ACCURACY.md, "Quadrant footprints and per-side light on
        // the fronts"); at 64^3 neither is on them. Its quadrants are the pixels' only: the
        // bounce's tripled the frame for no FLIP and are on neither front (they take the Cornell
        // box's walls a few percent lower and keep a closed room's sky out: ACCURACY.md,
        // "Quadrants where they pay"). Its cone samples are two-tap: 0.0999 -> 0.0979 FLIP on
        // the Cornell box and 0.1158 -> 0.1030 on Sponza for 1.9 times its frame, the top of
        // both fronts (ACCURACY.md, "Two-tap samples on the fronts"); the others keep
        // trilinear samples, which cost half. Every preset sets both footprints, which cost more than
        // any other knob. What the cones see of a plane from behind: `ultra`, the default, leaves
        // out the backs that close a solid (at 128^3 as good as lit backs on the Cornell box's
        // front and better on Sponza's, and not growing with the grid as lit backs do); the
        // others keep lit backs, which their sweeps put ahead (32^3 and 64^3 voxels hold too few
        // closed pockets, and `max`'s quadrants already count a block beside the cone once:
        // ACCURACY.md, "Backs that close a solid").
        let (voxels, cones, bounces, downsample, attenuation, footprint, backs) = match self {
            Preset::Low => ("32", "4", "1", "2", "\"n-dot-l\"", "\"whole\"", "\"lit\""),
            Preset::Medium => ("64", "9", "1", "2", "\"normal-weighted\"", "\"whole\"", "\"lit\""),
            Preset::High => ("64", "16", "1", "2", "\"normal-weighted\"", "\"whole\"", "\"lit\""),
            Preset::Ultra => ("128", "16", "1", "1", "\"n-dot-l\"", "\"whole\"", "\"closed\""),
            Preset::Max => ("128", "16", "1", "2", "\"per-side\"", "\"quadrants\"", "\"lit\""),
        };
        let filter = if self == Preset::Max { "\"two-tap\"" } else { "\"trilinear\"" };
        let values: [(&str, &str); 13] = [
            ("cone_filter", filter),
            ("attenuation", attenuation),
            ("footprint", footprint),
            ("plane_backs", backs),
            ("bounce_footprint", "\"whole\""),
            ("voxel_resolution", voxels),
            ("diffuse_cones", cones),
            ("diffuse_cone_angle", "0"),
            ("step", "0.5"),
            ("bounces", bounces),
            ("downsample", downsample),
            ("ao", "false"),
            ("bounce_interleave", "4"),
        ];
        let mut out = vec![("gi.mode".to_string(), "\"vct\"".to_string())];
        out.extend(values.iter().map(|(k, v)| (format!("gi.{k}"), v.to_string())));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::ValueEnum;

    #[test]
    fn every_preset_is_a_valid_gi_table_and_they_rise_in_cost() {
        let mut last = (0, 0, 0, 0, 0);
        for p in Preset::value_variants() {
            let mut table = toml::Table::new();
            for (k, v) in p.overrides() {
                let key = k.strip_prefix("gi.").unwrap().to_string();
                let value: toml::Value = toml::from_str::<toml::Table>(&format!("x = {v}")).unwrap()["x"].clone();
                table.insert(key, value);
            }
            let gi: crate::scene::GiSettings = table.try_into().expect("preset keys are [gi] keys");
            gi.validate().unwrap_or_else(|(k, m)| panic!("{p:?}: gi.{k}: {m}"));
            // Each level costs more: more bounces, or as many on more voxels, or with quadrant
            // footprints, or with more cones or at full resolution.
            let quadrants = (gi.footprint == crate::scene::Footprint::Quadrants) as u32;
            let cost = (gi.bounces, gi.voxel_resolution, quadrants, gi.diffuse_cones, 8 - gi.downsample);
            assert_eq!(gi.bounce_interleave, crate::scene::GiSettings::default().bounce_interleave);
            assert!(cost > last, "{p:?}");
            last = cost;
            if *p == Preset::Ultra {
                let d = crate::scene::GiSettings::default();
                assert_eq!(
                    (gi.voxel_resolution, gi.diffuse_cones, gi.bounces, gi.downsample, gi.step, gi.ao),
                    (d.voxel_resolution, d.diffuse_cones, d.bounces, d.downsample, d.step, d.ao),
                    "ultra is the scene-file default"
                );
                assert_eq!(gi.bounce_interleave, d.bounce_interleave);
                assert_eq!(
                    (gi.attenuation, gi.footprint, gi.bounce_footprint, gi.plane_backs, gi.cone_filter),
                    (d.attenuation, d.footprint, d.bounce_footprint, d.plane_backs, d.cone_filter)
                );
            }
        }
    }
}
